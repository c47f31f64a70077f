"""A table of another size from the regulation one: what a tracker needs to know of a table it was given only
the field size of (`track_video --field-size LENGTH,WIDTH`, shared/CONTRACT.md).

Tracking needs the field's size (the homography's corners, the walls) and, for its hints, where the rods
and figures are. A table that is not the regulation one keeps the regulation layout's proportions here: each
rod keeps its share of the length, and the figures' spacing and the slides' travel their share of the width,
so the figures still fit between the walls (the parameter file's validator refuses figures that reach them,
which the regulation layout does on a narrower table). The goal mouth keeps its width where it fits. The
ball, the figures' own size and the drives are unchanged.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

import yaml

from .table_params import ParamsError, load_params, validate

SIZE_RANGE = (0.3, 3.0)  # m: a field's length and width; outside this it is no foosball table
MAX_GOAL_SHARE = 0.4  # of the width: a goal mouth wider than this on a narrow table keeps this share


def parse_field_size(text: str, option: str = "--field-size") -> tuple[float, float]:
    """`LENGTH,WIDTH` in m (length along y between the end walls, width along x between the side walls)."""
    parts = [p.strip() for p in str(text).split(",")]
    try:
        length, width = (float(p) for p in parts)
    except ValueError:
        raise ParamsError(f"{option}: `{text}` is not LENGTH,WIDTH in metres (e.g. 1.12,0.64)") from None
    low, high = SIZE_RANGE
    for name, value in (("length", length), ("width", width)):
        if not (math.isfinite(value) and low <= value <= high):
            raise ParamsError(f"{option}: the field's {name} {value:g} m is outside {low:g}-{high:g} m (metres, not cm?)")
    if width >= length:
        raise ParamsError(f"{option}: LENGTH ({length:g} m, between the end walls) comes first and is the longer side")
    return length, width


def with_field_size(tree: dict[str, Any], length: float, width: float) -> dict[str, Any]:
    """The parameter tree resized to a `length` x `width` m field (see the module's docstring); validated."""
    resized = copy.deepcopy(tree)
    field = resized["field"]
    along, across = length / float(field["length"]), width / float(field["width"])
    field["length"], field["width"] = float(length), float(width)
    field["goal_width"] = float(min(field["goal_width"], MAX_GOAL_SHARE * width))
    for rod in resized["rods"]["layout"].values():
        rod["y"] = float(rod["y"]) * along
        rod["spacing"] = float(rod["spacing"]) * across
        rod["travel"] = float(rod["travel"]) * across
    validate(resized, f"a {length:g} x {width:g} m table")
    return resized


def write_field_sized(params_file: str | Path | None, length: float, width: float, out: str | Path) -> Path:
    """`params_file` (the regulation table for None) resized and written whole to `out`, for the tools that
    take a parameter file."""
    path = Path(out)
    path.write_text(yaml.safe_dump(with_field_size(load_params(params_file), length, width), sort_keys=False))
    return path
