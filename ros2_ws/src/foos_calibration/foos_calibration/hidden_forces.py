"""The generators' hidden table: its effects in the contract's vocabulary, and the forces that carry them.

The generators hide effects by a mechanism outside the model `calibrate` fits: forces and torques on the
nominal MuJoCo ball from a Python loop (a slope as a force, rolling resistance as a torque against the
spin...), where the fitted model changes gravity, friction, fluid parameters and a height field. Both
the free-roll generator (generate.HiddenTable, a ball-only table) and the game generator (games.play, the
full table with its figures) apply `ball_wrench`.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import mujoco
import numpy as np

from foos_sim.effects import EFFECT_NAMES, ROLLING_MASS_FACTOR, Dent, EffectError

from .table_shapes import SurfaceShape, WallSegment, shapes_gradient


@dataclass
class HiddenEffects:
    """The generator's truth, in the contract's vocabulary (slopes, decelerations, rates...)."""

    slope: tuple[float, float] = (0.0, 0.0)
    rolling_deceleration: float | None = None  # None: the nominal one
    viscous_rate: float = 0.0
    drag_coefficient: float = 0.0
    dents: list[Dent] = field(default_factory=list)
    restitution: float | None = None  # all walls; None: nominal
    shapes: list[SurfaceShape] = field(default_factory=list)  # outside the vocabulary (table_shapes)
    soft_walls: list[WallSegment] = field(default_factory=list)  # stretches of wall with a restitution of their own

    def restitution_at(self, wall: str, x: float, y: float) -> float | None:
        """The hidden restitution of a bounce on `wall` at (x, y); None: the nominal one."""
        for segment in self.soft_walls:
            if segment.holds(wall, x, y):
                return segment.coefficient
        return self.restitution

    @classmethod
    def from_effects(cls, effects: Sequence[dict]) -> "HiddenEffects":
        hidden = cls()
        for effect in effects:
            name, p = effect.get("name"), effect.get("params", {})
            if name not in EFFECT_NAMES:
                raise EffectError(f"unknown effect `{name}`")
            try:
                if name == "table_tilt":
                    hidden.slope = (float(p["slope_x"]), float(p["slope_y"]))
                elif name == "rolling_resistance":
                    hidden.rolling_deceleration = float(p["deceleration"])
                elif name == "viscous_damping":
                    hidden.viscous_rate = float(p["rate"])
                elif name == "air_drag":
                    hidden.drag_coefficient = float(p["coefficient"])
                elif name == "surface_dent":
                    hidden.dents.append(Dent(float(p["x"]), float(p["y"]), float(p["radius"]), float(p["depth"])))
                elif name == "wall_restitution":
                    hidden.restitution = float(p["coefficient"])
            except KeyError as missing:
                raise EffectError(f"effect `{name}` needs the parameter {missing}") from None
        return hidden


def dent_gradient(dents: Sequence[Dent], x: np.ndarray, y: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Surface gradient (dh/dx, dh/dy) of cosine-bowl dents at points (x, y)."""
    gx = np.zeros_like(np.asarray(x, dtype=float))
    gy = np.zeros_like(gx)
    for dent in dents:
        dx, dy = x - dent.x, y - dent.y
        d = np.hypot(dx, dy)
        inside = (d < dent.radius) & (d > 1e-9)
        # h = -depth/2 (1 + cos(pi d / R))  ->  dh/dd = depth/2 * pi/R * sin(pi d / R)
        dh = np.where(inside, dent.depth * 0.5 * np.pi / dent.radius * np.sin(np.pi * np.minimum(d, dent.radius) / dent.radius), 0.0)
        safe = np.where(d > 1e-9, d, 1.0)
        gx = gx + dh * dx / safe
        gy = gy + dh * dy / safe
    return gx, gy



@dataclass
class BallBody:
    """What the forces need to know of the ball and the nominal table."""

    mass: float
    radius: float
    gravity: float
    nominal_rolling: float  # m/s^2, the model's own rolling deceleration
    field_half: tuple[float, float] = (0.34, 0.6)  # m, the field's half width and half length (where shapes sit)


def world_spin(quaternion: np.ndarray, local_spin: np.ndarray) -> np.ndarray:
    """A free joint's angular velocity (body frame in qvel) in the world frame."""
    omega = np.zeros(3)
    mujoco.mju_rotVecQuat(omega, local_spin, quaternion)
    return omega


def ball_wrench(hidden: HiddenEffects, ball: BallBody, position: np.ndarray, velocity: np.ndarray,
                omega: np.ndarray) -> np.ndarray:
    """Force and torque (world frame, for MuJoCo's xfrc_applied) of the hidden effects on the ball (omega: its
    spin in the world frame).

        Each acts the way its physical cause acts, so sliding after a bounce is right too:
        slope, dent and air drag pull at the centre; rolling resistance is a torque against the
        spin (as a deformed cloth resists the rolling); Stokes damping is a force on the centre and
        a torque on the spin in Stokes' 6:8 proportion. For a rolling ball each gives the contract's
        deceleration, e.g. a torque T slows it at T / (7/5 m r).
        """
    h, m, r = hidden, ball.mass, ball.radius
    v = velocity[:2]
    speed = math.hypot(v[0], v[1])
    force = np.zeros(3)
    torque = np.zeros(3)
    force[:2] += m * ball.gravity * np.asarray(h.slope)
    if h.dents:
        gx, gy = dent_gradient(h.dents, np.array([position[0]]), np.array([position[1]]))
        force[:2] -= m * ball.gravity * np.array([gx[0], gy[0]])
    if h.shapes:
        gx, gy = shapes_gradient(h.shapes, np.array([position[0]]), np.array([position[1]]), ball.field_half)
        force[:2] -= m * ball.gravity * np.array([gx[0], gy[0]])
    spin = math.hypot(omega[0], omega[1])
    if h.rolling_deceleration is not None and spin > 1e-6:
        # Only the difference to the model's own rolling friction; faded out near rest so a
        # weaker table does not push a resting ball.
        fade = min(1.0, spin * r / 0.02)
        torque[:2] -= ROLLING_MASS_FACTOR * m * r * (h.rolling_deceleration - ball.nominal_rolling) * fade * omega[:2] / spin
    force[:2] -= 0.6 * m * h.viscous_rate * v
    torque[:2] -= 0.8 * m * r * r * h.viscous_rate * omega[:2]
    force[:2] -= ROLLING_MASS_FACTOR * m * h.drag_coefficient * speed * v
    return np.concatenate([force, torque])
