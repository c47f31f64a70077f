"""The contract's effect vocabulary as physical extensions of the MuJoCo model.

An effect in a parameter file (`effects: [{name: table_tilt, params: {...}}]`) changes physics the way
the real cause would, never by a correction added on top of the simulation:

| effect               | MuJoCo mechanism                                                          |
|----------------------|---------------------------------------------------------------------------|
| table_tilt           | the gravity vector, tilted to the surface gradient                         |
| rolling_resistance   | the ball-field rolling friction                                            |
| viscous_damping      | the fluid model's viscosity (Stokes drag on the ball's ellipsoid model)    |
| air_drag             | the fluid model's density (blunt quadratic drag; lift and buoyancy offset) |
| surface_dent         | a height field in place of the flat field geom (reference physics); on the |
|                      | fast physics the dent's slope pushes the ball (DentSlopes)                 |
| wall_restitution     | the ball-wall contacts' damping (all walls, or the named one)              |
| figure_restitution   | the ball-figure contacts' restitution (every figure): damping, and the fast |
|                      | physics' impact rule                                                        |
| rod_latency,         | not MuJoCo: the drives' dead time, speed and acceleration limits shape the |
| rod_speed_limit,     | velocity target of the servos (foos_sim.drive_limits.DriveShaper, applied  |
| rod_acceleration_... | by TableSimulation on both physics)                                         |

The contract defines each parameter by what is observed on a rolling ball (a deceleration), so the
conversions below include the rolling ball's effective mass, 7/5 of its mass: a force at the centre
also has to slow the ball's spin through the field friction.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from .drive_limits import DRIVE_EFFECT_NAMES, DriveEffectError, drive_limits_from_effects

# The table and ball effects (the free-roll calibration's vocabulary); the drive effects are DRIVE_EFFECT_NAMES.
EFFECT_NAMES = (
    "table_tilt",
    "rolling_resistance",
    "viscous_damping",
    "air_drag",
    "surface_dent",
    "wall_restitution",
)

# Seen only in games (the ball meets moving figures): the ball-figure contacts' restitution.
FIGURE_EFFECT_NAMES = ("figure_restitution",)
MODEL_EFFECT_NAMES = EFFECT_NAMES + FIGURE_EFFECT_NAMES + DRIVE_EFFECT_NAMES  # every effect a parameter file may carry

# Rolling solid sphere: m_eff = m + I / r^2 = 7/5 m.
ROLLING_MASS_FACTOR = 7.0 / 5.0


class EffectError(ValueError):
    """An effect the model cannot express (unknown name, missing or unphysical parameter)."""


@dataclass(frozen=True)
class Dent:
    x: float
    y: float
    radius: float
    depth: float  # > 0 a depression, < 0 a bump

    def height(self, distance):
        """Surface height (m, negative in a dent) at a horizontal distance from the centre: a cosine bowl."""
        d = np.asarray(distance, dtype=float)
        inside = d < self.radius
        return np.where(inside, -self.depth * 0.5 * (1.0 + np.cos(np.pi * np.minimum(d, self.radius) / self.radius)), 0.0)


@dataclass
class Physics:
    """Physical quantities the model builder needs, after the effects are applied."""

    gravity: tuple[float, float, float]
    rolling_deceleration: float
    viscosity: float = 0.0  # Pa s, MuJoCo option viscosity
    air_density: float = 0.0  # kg/m^3, MuJoCo option density
    ball_blunt_drag: float = 0.0  # the ball geom's blunt drag coefficient in the ellipsoid fluid model
    wall_restitution: dict[str, float] = field(default_factory=dict)  # wall geom name (or "*") -> e
    figure_restitution: float | None = None  # every figure; None: the parameter file's figures.restitution
    dents: list[Dent] = field(default_factory=list)


def _param(effect: dict, key: str, *, positive: bool = False, optional: bool = False) -> Any:
    params = effect.get("params") or {}
    if key not in params:
        if optional:
            return None
        raise EffectError(f"effect `{effect['name']}` needs parameter `{key}`")
    value = params[key]
    if isinstance(value, str):
        return value
    value = float(value)
    if not math.isfinite(value) or (positive and value <= 0):
        raise EffectError(f"effect `{effect['name']}`: `{key}` must be a {'positive ' if positive else ''}finite number")
    return value


def viscosity_for_rate(rate: float, ball_radius: float, ball_mass: float) -> float:
    """Viscosity whose Stokes force (6 pi mu r v) and torque (8 pi mu r^3 w) slow a rolling ball at `rate` * v."""
    return rate * ball_mass / (10.0 * math.pi * ball_radius)


def density_for_drag(coefficient: float, ball_radius: float, ball_mass: float, blunt_drag: float,
                     rolling_deceleration: float = 0.0, gravity: float = 9.81) -> float:
    """Density whose blunt drag (blunt_drag * rho * pi r^2 * v^2) slows a rolling ball at `coefficient` * v^2.

    The ellipsoid fluid model also gives a rolling ball an added-mass lift, rho V / 2 * omega * v =
    rho V v^2 / (2 r), which unloads the field contact and so lowers the rolling resistance in
    proportion to v^2; measured on MuJoCo it takes 3 % off the drag at the nominal rolling resistance.
    The density is solved with that loss included, so the observed coefficient is the contract's.
    """
    volume = 4.0 / 3.0 * math.pi * ball_radius**3
    per_density = blunt_drag * math.pi * ball_radius**2 / (ROLLING_MASS_FACTOR * ball_mass)
    lift_loss = rolling_deceleration * volume / (2.0 * ball_radius * ball_mass * gravity)
    return coefficient / (per_density - lift_loss)


def buoyancy_factor(air_density: float, ball_radius: float, ball_mass: float) -> float:
    """Weight over (weight - buoyancy): the fluid model's buoyancy unloads the field contact."""
    volume = 4.0 / 3.0 * math.pi * ball_radius**3
    return ball_mass / (ball_mass - air_density * volume)


BLUNT_DRAG = 0.5  # MuJoCo's default blunt drag coefficient of the ellipsoid fluid model


def resolve(params: dict) -> Physics:
    """Physical quantities of the table described by a validated parameter tree."""
    g = float(params["gravity"])
    ball = params["ball"]
    physics = Physics(gravity=(0.0, 0.0, -g), rolling_deceleration=float(ball["rolling_deceleration"]))
    seen: set[str] = set()
    drag_coefficient = None
    try:
        drive_limits_from_effects(params.get("effects"))  # the drive effects are TableSimulation's: checked here
    except DriveEffectError as error:
        raise EffectError(str(error)) from None
    for effect in params.get("effects", []) or []:
        name = effect.get("name")
        if name in DRIVE_EFFECT_NAMES:
            continue
        if name not in EFFECT_NAMES + FIGURE_EFFECT_NAMES:
            raise EffectError(f"unknown effect `{name}` (known: {', '.join(MODEL_EFFECT_NAMES)})")
        key = name if name != "wall_restitution" else f"{name}:{(effect.get('params') or {}).get('wall', '*')}"
        if key in seen and name != "surface_dent":
            raise EffectError(f"effect `{name}` is given twice")
        seen.add(key)
        if name == "table_tilt":
            sx, sy = _param(effect, "slope_x"), _param(effect, "slope_y")
            norm = math.sqrt(1.0 + sx * sx + sy * sy)
            # The surface descends toward +x by slope_x: in the table frame gravity leans toward +x.
            physics.gravity = (g * sx / norm, g * sy / norm, -g / norm)
        elif name == "rolling_resistance":
            physics.rolling_deceleration = _param(effect, "deceleration", positive=True)
        elif name == "viscous_damping":
            rate = _param(effect, "rate", positive=True)
            physics.viscosity = viscosity_for_rate(rate, float(ball["radius"]), float(ball["mass"]))
        elif name == "air_drag":
            drag_coefficient = _param(effect, "coefficient", positive=True)
        elif name == "surface_dent":
            dent = Dent(
                x=_param(effect, "x"), y=_param(effect, "y"),
                radius=_param(effect, "radius", positive=True), depth=_param(effect, "depth"),
            )
            physics.dents.append(dent)
        elif name == "wall_restitution":
            e = _param(effect, "coefficient", positive=True)
            if e >= 1.0:
                raise EffectError("effect `wall_restitution`: `coefficient` must be below 1")
            wall = (effect.get("params") or {}).get("wall", "*")
            physics.wall_restitution[str(wall)] = e
        elif name == "figure_restitution":
            e = _param(effect, "coefficient", positive=True)
            if e >= 1.0:
                raise EffectError("effect `figure_restitution`: `coefficient` must be below 1")
            physics.figure_restitution = e
    if drag_coefficient is not None:
        # After the loop: the lift correction needs the final rolling resistance.
        physics.ball_blunt_drag = BLUNT_DRAG
        physics.air_density = density_for_drag(
            drag_coefficient, float(ball["radius"]), float(ball["mass"]), BLUNT_DRAG, physics.rolling_deceleration, g)
    return physics


class DentSlopes:
    """The dents on the fast physics: the force of each dent's slope on a ball on the field, -m g grad h.

    A ball rolling over a surface z = h(x, y) of small slope moves as on the flat field pushed by that
    force at its centre (the rolling constraint makes it 5/7 g s, as a tilt does). Off the field (higher
    than DentSlopes.ON_FIELD above it) the ball feels none."""

    ON_FIELD = 0.001  # m of the ball's bottom above the field

    def __init__(self, dents: list[Dent], ball_mass: float, gravity: float, ball_radius: float):
        self.dents = list(dents)
        self.weight = ball_mass * gravity
        self.ball_radius = ball_radius

    def force(self, x: float, y: float, z: float) -> tuple[float, float]:
        if z - self.ball_radius > self.ON_FIELD:
            return 0.0, 0.0
        slope_x = slope_y = 0.0
        for dent in self.dents:
            dx, dy = x - dent.x, y - dent.y
            d = math.hypot(dx, dy)
            if 0.0 < d < dent.radius:
                # h = -depth (1 + cos(pi d / R)) / 2, so dh/dd = depth pi / (2 R) sin(pi d / R).
                slope = 0.5 * dent.depth * math.pi / dent.radius * math.sin(math.pi * d / dent.radius)
                slope_x += slope * dx / d
                slope_y += slope * dy / d
        return -self.weight * slope_x, -self.weight * slope_y

