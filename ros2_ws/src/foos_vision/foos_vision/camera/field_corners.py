"""The field's four corners in the image, in place of tags, for a camera that does not move.

`--field-corners U1,V1,U2,V2,U3,V3,U4,V4` (CONTRACT.md, "Commands a user runs") gives the pixels where the
playing surface meets the walls at the table frame's (-x,-y), (+x,-y), (+x,+y) and (-x,+y): four points on the
surface (z = 0) of a field the parameter file sizes. geometry.fit_field_corners turns them into the ball-plane
mapping the tags would give.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence, Union

import numpy as np

from foos_core.markers import MarkerLayout, load_markers

from ..errors import VisionError

CORNER_ORDER = "(-x,-y), (+x,-y), (+x,+y), (-x,+y)"
# A corner angle this close to 180 degrees is three corners on one line: no quadrilateral a camera makes of a
# rectangle the size of a table (its widest angle in the steepest view a table is filmed from is far below).
MAX_CORNER_ANGLE_DEG = 175.0
MIN_SIDE_PX = 8.0  # shorter than this and 2 px of clicking error is a quarter of the field


class FieldCornersError(VisionError):
    """Field corners that cannot be the playing field's corners in this camera's image."""


@dataclass(frozen=True)
class FieldCorners:
    """The playing field's corners in the (distorted) image, pixels, in CORNER_ORDER."""

    pixels: np.ndarray  # (4, 2)
    option: str = "--field-corners"  # what the user gave them as, for the errors

    def check_in_image(self, width: int, height: int) -> None:
        """FieldCornersError unless every corner lies in a width x height image (pixel centres at integers)."""
        for index, (u, v) in enumerate(self.pixels, start=1):
            if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
                raise FieldCornersError(f"{self.option}: corner {index} ({u:g}, {v:g}) lies outside the "
                                        f"{width}x{height} image")


def parse_field_corners(value: Union[str, Sequence[float]], option: str = "--field-corners") -> FieldCorners:
    """U1,V1,...,U4,V4 as one string or a list of 8 numbers, checked to be a convex quadrilateral in the order
    a camera above the table sees them; FieldCornersError (one line, naming option) otherwise."""
    if isinstance(value, str):
        parts = [p.strip() for p in value.replace(";", ",").split(",")]
        if parts and parts[-1] == "":
            parts = parts[:-1]
        try:
            numbers = [float(p) for p in parts]
        except ValueError:
            raise FieldCornersError(f"{option}: `{value}` is not a comma-separated list of pixel coordinates "
                                    f"U1,V1,U2,V2,U3,V3,U4,V4") from None
    else:
        try:
            numbers = [float(p) for p in value]
        except (TypeError, ValueError):
            raise FieldCornersError(f"{option}: {value!r} is not a list of 8 pixel coordinates") from None
    if len(numbers) != 8:
        raise FieldCornersError(f"{option} takes 8 numbers U1,V1,U2,V2,U3,V3,U4,V4 (pixels of the field's corners "
                                f"at {CORNER_ORDER}), got {len(numbers)}")
    if not all(math.isfinite(n) for n in numbers):
        raise FieldCornersError(f"{option}: the pixel coordinates must be finite numbers")
    pixels = np.array(numbers, float).reshape(4, 2)
    _check_quadrilateral(pixels, option)
    return FieldCorners(pixels, option)


def _check_quadrilateral(pixels: np.ndarray, option: str) -> None:
    sides = np.roll(pixels, -1, axis=0) - pixels
    lengths = np.linalg.norm(sides, axis=1)
    if np.min(lengths) < MIN_SIDE_PX:
        i = int(np.argmin(lengths))
        raise FieldCornersError(f"{option}: corners {i + 1} and {(i + 1) % 4 + 1} are {lengths[i]:.1f} px apart; "
                                f"the field's corners are far apart in any view of the table")
    # Turning at each corner: the cross product of the side into it and the side out of it.
    into = np.roll(sides, 1, axis=0)
    turns = into[:, 0] * sides[:, 1] - into[:, 1] * sides[:, 0]
    cosines = -np.sum(into * sides, axis=1) / (np.roll(lengths, 1) * lengths)
    angles = np.degrees(np.arccos(np.clip(cosines, -1.0, 1.0)))
    if np.max(angles) > MAX_CORNER_ANGLE_DEG:
        i = int(np.argmax(angles))
        raise FieldCornersError(f"{option}: corner {i + 1} lies on the line through its neighbours "
                                f"({angles[i]:.0f} degrees); these are not the corners of a field")
    if np.all(turns > 0):
        # A camera above the table sees the stated order counter-clockwise on the screen (v down: every turn
        # negative). The other way round is the field's mirror image: two corners exchanged, or a mirrored video.
        raise FieldCornersError(f"{option}: the corners go round the field clockwise on the screen; a camera above "
                                f"the table sees {CORNER_ORDER} go round counter-clockwise: check their order")
    if not np.all(turns < 0):
        raise FieldCornersError(f"{option}: the corners do not make a convex quadrilateral in the order given "
                                f"(its sides cross, or a corner points inward); give them in the order {CORNER_ORDER}")


FieldReference = Union[MarkerLayout, FieldCorners]


def field_reference(markers: Optional[str], corners: Union[str, Sequence[float], None],
                    names: tuple[str, str] = ("--markers", "--field-corners")) -> FieldReference:
    """What fixes the table in the image: the markers file's tags or the field's corners, exactly one of them."""
    given = [name for name, value in zip(names, (markers, corners)) if option_given(value)]
    if len(given) != 1:
        which = "both" if given else "neither"
        raise VisionError(f"give exactly one of {names[0]} (a markers YAML of the tags on the table) and {names[1]} "
                          f"(the field's corners in pixels), not {which}")
    if option_given(markers):
        return load_markers(markers)
    return parse_field_corners(corners, names[1])


def option_given(value) -> bool:
    """An option's value says something: not None, not blank, not an empty list."""
    if value is None:
        return False
    if isinstance(value, str):
        return value.strip() != ""
    return len(value) > 0
