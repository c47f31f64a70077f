"""The table's parameter file: loading, layering and validation.

A parameter file is YAML. The shipped `params/regulation_table.yaml` is complete. Any other file may
name a `base` file (relative to itself, or `regulation_table` for the shipped one) and hold only the
keys it changes; mappings merge key by key, everything else replaces. A calibrated file written by
`calibrate` is such a file.
"""
from __future__ import annotations

import copy
import math
from pathlib import Path
from typing import Any

from .yaml_files import read_mapping

PARAMS_DIR = Path(__file__).resolve().parent / "params"
DEFAULT_PARAMS_FILE = PARAMS_DIR / "regulation_table.yaml"
REFERENCE_PARAMS_FILE = PARAMS_DIR / "reference_table.yaml"  # the regulation table on the 20 kHz reference physics
SERVO_PARAMS_FILE = PARAMS_DIR / "servo_table.yaml"  # the regulation table with the former 40 rad/s velocity servos
SERVO_REFERENCE_PARAMS_FILE = PARAMS_DIR / "servo_reference_table.yaml"  # the same on the 20 kHz reference physics
ROBOT_PARAMS_FILE = PARAMS_DIR / "robot_table.yaml"  # the regulation table with a robot table's jerk-limited drives
ROBOT_REFERENCE_PARAMS_FILE = PARAMS_DIR / "robot_reference_table.yaml"  # the same on the 20 kHz reference physics
DRIVE_KINDS = ("jerk_limited", "servo")


class ParamsError(ValueError):
    """A parameter file that cannot describe a table."""


def _deep_merge(base: dict, override: dict) -> dict:
    merged = copy.deepcopy(base)
    for key, value in override.items():
        if isinstance(value, dict) and isinstance(merged.get(key), dict):
            merged[key] = _deep_merge(merged[key], value)
        else:
            merged[key] = copy.deepcopy(value)
    return merged


def _resolve_base(reference: str, relative_to: Path) -> Path:
    if reference in ("regulation_table", "nominal", "default"):
        return DEFAULT_PARAMS_FILE
    path = Path(reference)
    return path if path.is_absolute() else (relative_to.parent / path)


def load_params(params_file: str | Path | None = None, _seen: tuple = ()) -> dict[str, Any]:
    """The complete, validated parameter tree of a table (the nominal one when params_file is None)."""
    path = Path(params_file) if params_file is not None else DEFAULT_PARAMS_FILE
    path = path.expanduser().resolve()
    if path in _seen:
        raise ParamsError(f"{path}: `base` files form a cycle")
    if not path.is_file():
        raise ParamsError(f"parameter file not found: {path}")
    tree = read_mapping(path, "parameter file", ParamsError)
    base = tree.pop("base", None)
    if base is not None:
        tree = _deep_merge(load_params(_resolve_base(str(base), path), _seen + (path,)), tree)
    validate(tree, source=str(path))
    return tree


def _positive(tree: dict, dotted: str, source: str) -> float:
    node: Any = tree
    for key in dotted.split("."):
        if not isinstance(node, dict) or key not in node:
            raise ParamsError(f"{source}: missing `{dotted}`")
        node = node[key]
    try:
        value = float(node)
    except (TypeError, ValueError):
        raise ParamsError(f"{source}: `{dotted}` must be a number, got {node!r}") from None
    if not math.isfinite(value) or value <= 0:
        raise ParamsError(f"{source}: `{dotted}` must be a positive number, got {node!r}")
    return value


def validate(tree: dict, source: str = "parameters") -> None:
    """Raise ParamsError with a one-line reason unless the tree describes a buildable table."""
    for dotted in (
        "gravity", "field.length", "field.width", "field.thickness", "field.goal_width",
        "field.goal_height", "field.goal_depth", "field.wall_height", "field.wall_thickness",
        "field.cover_height", "ball.radius", "ball.mass", "ball.sliding_friction",
        "ball.spin_friction", "ball.rolling_deceleration", "walls.restitution", "walls.friction",
        "figures.restitution", "figures.friction", "contact.natural_frequency",
        "contact.field_damping_ratio", "rods.axis_height", "rods.radius", "rods.mass",
        "rods.slide_speed_limit", "rods.rotate_speed_limit", "rods.slide_gain", "rods.rotate_gain",
        "rods.slide_force_limit", "rods.rotate_torque_limit", "figure.mass", "figure.foot_clearance",
        "figure.head_height", "solver.timestep",
    ):
        _positive(tree, dotted, source)
    for dotted in ("walls.restitution", "figures.restitution"):
        value = float(tree[dotted.split(".")[0]][dotted.split(".")[1]])
        if not value < 1.0:
            raise ParamsError(f"{source}: `{dotted}` must be in (0, 1), got {value}")
    ball = tree["ball"]
    # MuJoCo clamps every friction coefficient to at least 1e-5 (mjMINMU): a rolling friction of 1e-5 m
    # is the least rolling resistance the model can express.
    floor = 1e-5 * float(tree["gravity"]) / (1.4 * float(ball["radius"]))
    if float(ball["rolling_deceleration"]) < floor * 1.001:
        raise ParamsError(f"{source}: `ball.rolling_deceleration` below {floor:.4f} m/s^2 cannot be simulated "
                          "(MuJoCo's least friction coefficient is 1e-5)")
    field, figure, rods = tree["field"], tree["figure"], tree["rods"]
    if field["goal_width"] >= field["width"]:
        raise ParamsError(f"{source}: the goal mouth is wider than the field")
    if figure["head_height"] >= rods["axis_height"]:
        raise ParamsError(f"{source}: figure heads would hit the field when a rod turns (head_height >= axis_height)")
    layout = rods.get("layout")
    if not isinstance(layout, dict) or len(layout) != 8:
        raise ParamsError(f"{source}: `rods.layout` must describe the 8 rods")
    for name, rod in layout.items():
        for key in ("y", "figures", "spacing", "travel"):
            if key not in rod:
                raise ParamsError(f"{source}: rod `{name}` lacks `{key}`")
        reach = (rod["figures"] - 1) * rod["spacing"] / 2 + figure["foot_size"][0] / 2 + rod["travel"]
        if reach > field["width"] / 2 + 1e-9:
            raise ParamsError(f"{source}: rod `{name}` can push a figure into the side wall (reach {reach:.3f} m)")
    drive = rods.get("drive", "servo")
    if drive not in DRIVE_KINDS:
        raise ParamsError(f"{source}: `rods.drive` must be one of {', '.join(DRIVE_KINDS)}, got {drive!r}")
    if drive == "jerk_limited":
        for axis in ("slide", "rotate"):
            for kind in ("acceleration", "jerk"):
                _positive(tree, f"rods.{axis}_{kind}_limit", source)
    effects = tree.get("effects", [])
    if not isinstance(effects, list):
        raise ParamsError(f"{source}: `effects` must be a list")
    for effect in effects:
        if not isinstance(effect, dict) or "name" not in effect:
            raise ParamsError(f"{source}: each effect needs a `name` (and `params`)")
