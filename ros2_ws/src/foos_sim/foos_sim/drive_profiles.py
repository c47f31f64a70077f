"""Jerk-limited rod drives: each of the 16 axes follows its velocity command on an S-curve (foos_sim.scurve).

A servo drive's trajectory generator turns the velocity command into a setpoint within the drive's speed,
acceleration and jerk limits, and its current loop makes the axis follow that setpoint. Here the generator
is ProfileDrives and the loop is the MuJoCo velocity servo (kv, force limit) on each joint, stiff enough to
follow the setpoint within a fraction of a millisecond (`rods.*_gain`).

The contract's drive effects keep their meaning:
- `rod_latency`: the generator acts on the command received `delay` earlier (dead time, CommandHistory);
- `rod_speed_limit`: the setpoint never exceeds it (the lower of it and the nominal speed limit);
- `rod_acceleration_limit`: the setpoint's acceleration never exceeds it (the lower of it and the nominal one).

The generator re-plans from its own state (setpoint velocity and acceleration) whenever the command it acts
on changes; between changes it follows the plan exactly (scurve.evaluate), so re-planning adds no drift.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import numpy as np

from foos_core.names import AXES, COMMAND_SIZE, JOINT_NAMES

from . import scurve
from .drive_limits import CommandHistory, DriveLimits

BLOCK = 32  # setpoints planned for the next this many steps from one start (numpy passes, not one per step)
# ... evaluated this many steps at a time, as they are reached: a command every 10 steps (the RL env's and bench_sim's 50
# Hz) uses one chunk, and a chunk of 16 rows costs 3/4 of 32 rows' numpy passes. Each row is the same arithmetic
# from the block's start either way, so the setpoints do not depend on CHUNK.
CHUNK = 16
_TIME_EPS = 1e-9


@dataclass(frozen=True)
class ProfileLimits:
    """The nominal generator limits of the 16 drives (JOINT_NAMES order): speed, acceleration and jerk."""

    speed: np.ndarray
    acceleration: np.ndarray
    jerk: np.ndarray


def drive_kind(params: dict) -> str:
    return str(params["rods"].get("drive", "servo"))


def profile_limits(params: dict) -> Optional[ProfileLimits]:
    """The parameter tree's jerk-limited drive limits, or None for the plain velocity servos (`rods.drive`)."""
    rods = params["rods"]
    if drive_kind(params) != "jerk_limited":
        return None
    per_axis = {axis: [float(rods[f"{axis}_speed_limit"]), float(rods[f"{axis}_acceleration_limit"]),
                       float(rods[f"{axis}_jerk_limit"])] for axis in AXES}
    values = np.array([per_axis[name.rsplit("_", 1)[1]] for name in JOINT_NAMES])
    return ProfileLimits(values[:, 0].copy(), values[:, 1].copy(), values[:, 2].copy())


def effective_limits(nominal: ProfileLimits, effects: Optional[DriveLimits]) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(delay, speed, acceleration, jerk) per drive: the nominal generator under the drive effects."""
    if effects is None:
        return np.zeros(len(JOINT_NAMES)), nominal.speed, nominal.acceleration, nominal.jerk
    return (effects.delay, np.minimum(effects.speed, nominal.speed), np.minimum(effects.acceleration, nominal.acceleration),
            nominal.jerk)


class ProfileDrives:
    """The 16 drives' trajectory generators between set_command and the servos (see the module docstring).

    receive() takes a team's clipped command when it arrives; targets(time, h) gives the servo targets for
    an interval [time, time + h) (the setpoint at its middle), or None when they have not changed since the
    last call (the drives hold their targets)."""

    def __init__(self, nominal: ProfileLimits, effects: Optional[DriveLimits], lead: Optional[np.ndarray] = None):
        self.effects = effects
        # s per drive the servo targets run ahead of the setpoint: a velocity servo lags its target by its time
        # constant (inertia / gain), so one fed the setpoint that much ahead follows it without that lag.
        self.lead = np.zeros(len(JOINT_NAMES)) if lead is None else np.asarray(lead, dtype=float)
        self._max_lead = float(self.lead.max())
        self.delay, self.speed, self.accel, self.jerk = effective_limits(nominal, effects)
        self._negative_speed = -self.speed
        self._min_delay = float(self.delay.min())
        self.history = CommandHistory(self.delay)
        # Without dead time a drive acts on the last command at once: no history to search (every step counts).
        self._instant = not bool(np.any(self.delay > 0.0))
        self._latest = np.zeros(len(JOINT_NAMES))
        self._steps = np.arange(BLOCK) + 0.5
        # numba's import (about 0.5 s) only in a process that has jerk-limited drives (the servo table's need none).
        from . import scurve_lanes
        self._lanes = scurve_lanes
        self._limits = np.ascontiguousarray(np.stack([self.accel, self.jerk]), dtype=float)
        self._plan = np.zeros((scurve_lanes.PLAN_ROWS, len(JOINT_NAMES)))  # the current plan, packed (scurve_lanes)
        self._goal = np.zeros(len(JOINT_NAMES))
        self.reset()

    def reset(self) -> None:
        self.history.reset()
        self._latest[:] = 0.0
        self._plan[:] = 0.0
        self._lanes.replan(self._plan, 0.0, np.zeros(len(JOINT_NAMES)), self._limits)  # at rest, holding 0
        self._target = self._plan[self._lanes.TARGET].tolist()
        self.plan_time = 0.0
        self.settled_at = 0.0  # when every drive holds its target
        self.next_due = np.inf  # when a received command next starts acting
        self._block: Optional[np.ndarray] = None
        self._block_t0, self._block_h, self._block_rows = 0.0, 0.0, 0
        self._held = False  # the settled targets have been handed out

    def receive(self, time: float, team: int, command: np.ndarray) -> None:
        if self._instant:
            self._latest[team * COMMAND_SIZE:(team + 1) * COMMAND_SIZE] = command
        else:
            self.history.receive(time, team, command)
        self.next_due = min(self.next_due, time + self._min_delay)

    @property
    def plan(self) -> scurve.Profile:
        """The current plan as scurve.plan gives it (for scurve.evaluate; the step uses the packed rows)."""
        rows = self._plan.copy()
        lanes = self._lanes
        return scurve.Profile(v0=rows[lanes.V0], a0=rows[lanes.A0], jerk1=rows[lanes.JERK1], t1=rows[lanes.T1],
                              t2=rows[lanes.T2], jerk3=rows[lanes.JERK3], t3=rows[lanes.T3], target=rows[lanes.TARGET])

    def state(self, time: float) -> tuple[np.ndarray, np.ndarray]:
        """The setpoints' velocity and acceleration at `time` (on the current plan)."""
        velocity, acceleration = self._lanes.state(self._plan, time - self.plan_time)
        return velocity, acceleration

    def _update(self, time: float) -> None:
        commands = self._latest if self._instant else self.history.delayed_commands(time)
        goal = np.minimum(np.maximum(commands, self._negative_speed), self.speed, out=self._goal)
        targets = goal.tolist()
        if targets != self._target:  # (16 finite floats: cheaper as lists than np.array_equal)
            longest = self._lanes.replan(self._plan, time - self.plan_time, goal, self._limits)
            self._target = targets
            self.plan_time = time
            self.settled_at = time + longest
            self._block = None
            self._held = False
        self.next_due = np.inf if self._instant else self.history.next_due(time)

    def sub_targets(self, time: float, middles: np.ndarray) -> np.ndarray:
        """(n, 16) servo targets at `middles` (s after `time`: the sub-steps' middles), in one evaluation apart
        from targets()' block."""
        if time >= self.next_due - _TIME_EPS:
            self._update(time)
        out = np.empty((len(middles), len(self.lead)))
        self._lanes.velocities(self._plan, time - self.plan_time, middles, 1.0, self.lead, out, 0, len(middles))
        return out

    def targets(self, time: float, h: float) -> Optional[np.ndarray]:
        if time >= self.next_due - _TIME_EPS:
            self._update(time)
        if time + 0.5 * h + self._max_lead >= self.settled_at:
            if self._held:
                return None
            self._held = True
            return self._plan[self._lanes.TARGET].copy()
        block = self._block
        if block is not None and h == self._block_h:
            k = (time - self._block_t0) / h
            i = int(k + 0.5)
            if 0 <= i < BLOCK and abs(k - i) < 1e-6:
                if i >= self._block_rows:
                    self._evaluate_rows(max(i + 1, self._block_rows + CHUNK))
                return block[i]
        self._block = np.empty((BLOCK, len(self.lead)))
        self._block_t0, self._block_h, self._block_rows = time, h, 0
        self._evaluate_rows(CHUNK)
        return self._block[0]

    def _evaluate_rows(self, end: int) -> None:
        """The block's setpoints from its evaluated rows up to `end` (at most BLOCK)."""
        start, end = self._block_rows, min(end, BLOCK)
        self._lanes.velocities(self._plan, self._block_t0 - self.plan_time, self._steps, self._block_h, self.lead, self._block,
                               start, end)
        self._block_rows = end
