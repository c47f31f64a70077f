"""Hand-written controllers on the own-view observation: the scripted baseline and opponent.

Each active rod slides its nearest reachable figure under the ball (with a short look-ahead) and, when
the ball sits just in front of that figure, swings the foot through it (a kick toward the opponent's
goal). Rods that are not active are lifted horizontal so they neither block nor play.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foos_core.names import RODS

from .observation import ACTION_LIMIT, OWN_SLOT, wrap_angle

SLIDE_GAIN = 40.0        # 1/s, slide velocity per metre of error
ROTATE_GAIN = 25.0       # 1/s, rotation velocity per radian of error
LOOK_AHEAD = 0.05        # s, the ball's position is predicted this far ahead
KICK_REACH = 0.09        # m, ball centre ahead of the rod axis within which a swinging foot reaches it
KICK_HALF_WIDTH = 0.03   # m, |ball x - figure x| within which the foot meets the ball
LIFTED = np.pi / 2
# The lift-ahead rule (a residual base, foos_policy.actions): own rods more than LIFT_MARGIN ahead of the ball (toward
# the opponent's goal) hold their feet raised back at LIFT_AHEAD_ANGLE, so the own shots and passes go under them and
# the ball they sit in front of is not blocked by an own figure. Measured on the robot table, hardened reset, scripted
# opponent, camera loop (docs/measurements/policy-2026-11-28-lift-ahead-6.md, 200 episodes of seed 7): win 0.30, own
# goals 0.09, against 0.14 / 0.10 for the same hold with no lift; feet raised forward (+1.4) instead: 0.16-0.21;
# margins of 0 and 0.10 m: 0.17 and 0.15 (100 episodes).
LIFT_MARGIN = 0.04                 # m
LIFT_AHEAD_ANGLE = -1.4            # rad: feet back and up, nearly horizontal, over the ball's top
RESIDUAL_BASES = ("scripted", "lift-ahead")


@dataclass(frozen=True)
class RodGeometry:
    y: float                    # own view
    offsets: tuple[float, ...]  # figure x at slide 0
    travel: float


def own_rod_geometry(params: dict) -> dict[str, RodGeometry]:
    """Own-view geometry of the four own rods (the table is symmetric, so the home rods describe both)."""
    layout = params["rods"]["layout"]
    geometry = {}
    for rod in RODS:
        r = layout[f"home_{rod}"]
        n = int(r["figures"])
        geometry[rod] = RodGeometry(
            y=float(r["y"]),
            offsets=tuple((i - (n - 1) / 2) * float(r["spacing"]) for i in range(n)),
            travel=float(r["travel"]),
        )
    return geometry


def lift_ahead_angles(obs: np.ndarray, rod_y: np.ndarray) -> np.ndarray:
    """Per own rod (RODS order, own-view y in `rod_y`), the angle the lift-ahead rule holds its figures at."""
    return np.where(rod_y > float(obs[1]) + LIFT_MARGIN, LIFT_AHEAD_ANGLE, 0.0)


class ScriptedPolicy:
    """Tracks the ball with `active` rods and kicks; lifts the others. Acts on own-view observations."""

    def __init__(self, params: dict, command_limits, active: tuple[str, ...] = RODS, kick: bool = True):
        self.geometry = own_rod_geometry(params)
        self.limits = np.asarray(command_limits, dtype=float)
        self.active = tuple(active)
        self.kick = kick

    def predict(self, obs: np.ndarray) -> np.ndarray:
        command, _ = self.plan(obs)
        return (command / self.limits * ACTION_LIMIT).astype(np.float32)

    def plan(self, obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """This step's command in SI units (clipped to the drives' limits, command order) and which of the rods
        (RODS order) are kicking."""
        obs = np.asarray(obs, dtype=float)
        bx, by, bvx, bvy = obs[:4]
        tx = bx + LOOK_AHEAD * bvx
        command = np.zeros(8)
        kicking = np.zeros(len(RODS), dtype=bool)
        for r, rod in enumerate(RODS):
            slide, _, angle, _ = obs[4 + 4 * OWN_SLOT[rod]: 8 + 4 * OWN_SLOT[rod]]
            g = self.geometry[rod]
            if rod not in self.active:
                command[2 * r + 1] = ROTATE_GAIN * wrap_angle(LIFTED - angle)
                continue
            # the figure that can get under the ball with the least travel
            targets = [np.clip(tx - off, -g.travel, g.travel) for off in g.offsets]
            errors = [abs(tx - (off + t)) + 0.1 * abs(t - slide) for off, t in zip(g.offsets, targets)]
            best = int(np.argmin(errors))
            command[2 * r] = SLIDE_GAIN * (targets[best] - slide)
            figure_x = g.offsets[best] + slide
            ahead = by - g.y
            if self.kick and 0.0 < ahead < KICK_REACH and abs(bx - figure_x) < KICK_HALF_WIDTH:
                command[2 * r + 1] = self.limits[2 * r + 1]  # full swing toward the opponent's goal
                kicking[r] = True
            else:
                command[2 * r + 1] = ROTATE_GAIN * wrap_angle(0.0 - angle)
        return np.clip(command, -self.limits, self.limits), kicking
