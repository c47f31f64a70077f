"""Table shapes outside the contract's vocabulary, for the generators to hide.

A real table can be wrong in ways the vocabulary has no name for: a surface that sags into a bowl, a
top warped into a saddle by its frame, a ramp where a corner's board lifts. The generators hide these
so the calibration's generic correction (surface_correction) can be tested on shapes it was not built
around. Each shape is a height h(x, y) over the field (m, up positive); a rolling ball feels it as the
slope's pull -g grad h at its centre, as the generators' slopes and dents do (hidden_forces).

`--shape` text: KIND:key=value,... with
- `bowl:depth=D`: the field's centre D below its walls' middles, h = D ((x/W)^2 + (y/L)^2) / 2
  (W, L the field's half width and half length);
- `saddle:amplitude=A`: the two diagonals' corners A up and A down, h = A (x/W) (y/L);
- `ramp:corner=+x+y,rise=R,size=S`: within S of the corner, h = R (1 - d/S)^2 (d the distance to it);
- `soft_wall:wall=W,from=A,to=B,coefficient=E`: one stretch of a wall (W: side_neg_x, side_pos_x, end_home or
  end_away; A to B in m along it, y for a side wall and x for an end wall) bounces the ball back at E.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

SHAPE_KINDS = ("bowl", "saddle", "ramp", "soft_wall")
WALLS = ("side_neg_x", "side_pos_x", "end_home", "end_away")


class ShapeError(ValueError):
    """A shape's text that cannot be read."""


@dataclass(frozen=True)
class SurfaceShape:
    kind: str
    height: float  # m: the bowl's depth, the saddle's amplitude or the ramp's rise
    corner: tuple[int, int] = (1, 1)  # a ramp's corner: the signs of its x and y
    size: float = 0.2  # m, a ramp's reach from its corner

    def gradient(self, x: np.ndarray, y: np.ndarray, half: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
        """(dh/dx, dh/dy) at the points (x, y) of a field of half width and half length `half`."""
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        hw, hl = half
        if self.kind == "bowl":
            return self.height * x / hw**2, self.height * y / hl**2
        if self.kind == "saddle":
            return self.height * y / (hw * hl), self.height * x / (hw * hl)
        cx, cy = self.corner[0] * hw, self.corner[1] * hl
        dx, dy = x - cx, y - cy
        d = np.hypot(dx, dy)
        inside = (d < self.size) & (d > 1e-9)
        # h = R (1 - d/S)^2  ->  dh/dd = -2 R (1 - d/S) / S
        slope = np.where(inside, -2.0 * self.height * (1.0 - np.minimum(d, self.size) / self.size) / self.size, 0.0)
        safe = np.where(d > 1e-9, d, 1.0)
        return slope * dx / safe, slope * dy / safe

    def height_at(self, x: np.ndarray, y: np.ndarray, half: tuple[float, float]) -> np.ndarray:
        x, y = np.asarray(x, dtype=float), np.asarray(y, dtype=float)
        hw, hl = half
        if self.kind == "bowl":
            return self.height * ((x / hw) ** 2 + (y / hl) ** 2) / 2.0
        if self.kind == "saddle":
            return self.height * (x / hw) * (y / hl)
        d = np.hypot(x - self.corner[0] * hw, y - self.corner[1] * hl)
        return self.height * np.clip(1.0 - d / self.size, 0.0, None) ** 2

    def describe(self) -> str:
        if self.kind == "ramp":
            return (f"ramp {self.height * 1000:.1f} mm high at the {_corner_text(self.corner)} corner, "
                    f"{self.size * 1000:.0f} mm long")
        return f"{self.kind} {self.height * 1000:.1f} mm"


@dataclass(frozen=True)
class WallSegment:
    """A stretch of one wall with a restitution of its own."""

    wall: str  # side_neg_x, side_pos_x, end_home, end_away (as tracks.Bounce names them)
    start: float  # m along the wall: y for a side wall, x for an end wall
    end: float
    coefficient: float

    def holds(self, wall: str, x: float, y: float) -> bool:
        along = y if wall.startswith("side") else x
        return wall == self.wall and self.start <= along <= self.end

    def describe(self) -> str:
        axis = "y" if self.wall.startswith("side") else "x"
        return f"{self.wall} from {axis} {self.start:+.2f} to {self.end:+.2f} m: restitution {self.coefficient:.2f}"


def wall_at(x: float, y: float, half: tuple[float, float]) -> str:
    """The wall nearest the point (x, y) of a field of half sizes `half`."""
    if half[0] - abs(x) < half[1] - abs(y):
        return "side_pos_x" if x > 0 else "side_neg_x"
    return "end_away" if y > 0 else "end_home"


def _corner_text(corner: tuple[int, int]) -> str:
    return f"{'+' if corner[0] > 0 else '-'}x{'+' if corner[1] > 0 else '-'}y"


def parse_shape(text: str) -> SurfaceShape | WallSegment:
    """`bowl:depth=0.002`, `saddle:amplitude=0.002`, `ramp:corner=+x-y,rise=0.004,size=0.2` or
    `soft_wall:wall=side_pos_x,from=-0.2,to=0.2,coefficient=0.4`."""
    kind, _, rest = text.partition(":")
    if kind not in SHAPE_KINDS:
        raise ShapeError(f"unknown shape `{kind}` in `{text}`: expected one of {', '.join(SHAPE_KINDS)}")
    values: dict[str, str] = {}
    for item in filter(None, rest.split(",")):
        key, sep, value = item.partition("=")
        if not sep:
            raise ShapeError(f"shape `{text}`: `{item}` is not key=value")
        values[key.strip()] = value.strip()
    needed = {"bowl": ("depth",), "saddle": ("amplitude",), "ramp": ("corner", "rise", "size"),
              "soft_wall": ("wall", "from", "to", "coefficient")}[kind]
    missing = [k for k in needed if k not in values]
    unknown = [k for k in values if k not in needed]
    if missing or unknown:
        raise ShapeError(f"shape `{kind}` takes {', '.join(needed)}; "
                         f"{'missing ' + ', '.join(missing) if missing else 'unknown ' + ', '.join(unknown)}")
    if kind == "soft_wall":
        return _wall_segment(text, values)
    try:
        if kind == "ramp":
            corner = values["corner"].replace(" ", "")
            if len(corner) != 4 or corner[1] != "x" or corner[3] != "y" or corner[0] not in "+-" or corner[2] not in "+-":
                raise ShapeError(f"ramp corner `{values['corner']}`: expected e.g. +x-y")
            shape = SurfaceShape("ramp", float(values["rise"]), (1 if corner[0] == "+" else -1, 1 if corner[2] == "+" else -1),
                                 float(values["size"]))
            if not shape.size > 0:
                raise ShapeError(f"ramp size must be > 0, got {shape.size}")
        else:
            shape = SurfaceShape(kind, float(values[needed[0]]))
    except ValueError as error:
        if isinstance(error, ShapeError):
            raise
        raise ShapeError(f"shape `{text}`: {error}") from None
    if not math.isfinite(shape.height) or abs(shape.height) > 0.02:
        raise ShapeError(f"shape `{text}`: a height of {shape.height} m is not a table's (|h| <= 0.02 m)")
    return shape


def _wall_segment(text: str, values: dict[str, str]) -> WallSegment:
    if values["wall"] not in WALLS:
        raise ShapeError(f"soft_wall `{text}`: wall must be one of {', '.join(WALLS)}")
    try:
        segment = WallSegment(values["wall"], float(values["from"]), float(values["to"]), float(values["coefficient"]))
    except ValueError as error:
        raise ShapeError(f"shape `{text}`: {error}") from None
    if not segment.start < segment.end:
        raise ShapeError(f"soft_wall `{text}`: `from` must be below `to`")
    if not 0.0 < segment.coefficient <= 1.0:
        raise ShapeError(f"soft_wall `{text}`: a coefficient in (0, 1], got {segment.coefficient}")
    return segment


def shapes_gradient(shapes, x: np.ndarray, y: np.ndarray, half: tuple[float, float]) -> tuple[np.ndarray, np.ndarray]:
    gx = np.zeros_like(np.asarray(x, dtype=float))
    gy = np.zeros_like(gx)
    for shape in shapes:
        sx, sy = shape.gradient(x, y, half)
        gx, gy = gx + sx, gy + sy
    return gx, gy
