"""What a policy's action asks of the rods: the paper's velocities, or position targets (ROS-free).

- `velocity`: the paper's action box [-20, 20]^8, each entry a share of its drive's command limit (the
  contract's velocity command, scaled).
- `position`: [-1, 1]^8, per own rod a slide target (a share of the rod's travel either side of centre) and
  a rotation target (a share of pi, 0 = figures hanging down). At each control step a braking-curve
  controller (PositionTargets) turns the targets into the paper's velocity action, so policy_node, the bag
  and the contract still carry velocity commands, and evaluation and play use one code path.

Why position targets: a robot table's rods (TU Darmstadt's, Jaykixx/Foosball) are driven to positions by
their own jerk-limited servo loop. On those drives a velocity action is hard to learn with: a constant action
spins a rod or runs it into its stop, and a random one flails, so own goals come from the home rods sweeping
the ball back. A constant position action holds the rods in place as a wall, and a kick is a target flipped
from behind the ball to beyond it.
"""
from __future__ import annotations

import numpy as np

from foos_core.names import RODS

from .observation import ACTION_LIMIT, OWN_SLOT
from .scripted import own_rod_geometry

ACTION_MODES = ("velocity", "position")
POSITION_ACTION_LIMIT = 1.0

# The braking curve: the speed from which a jerk-limited axis (from zero acceleration) can still stop within
# the distance e is (jerk e^2)^(1/3); above the acceleration limit's sqrt(acceleration e) it is capped by that.
# Near the target the curve's slope grows without bound, and with a command held for one 20 ms control step on
# a lagging drive that is a limit cycle (a goalie swung +-0.05 rad at 7 rad/s around its target), so close in
# the speed is proportional to the error instead. The margin, lead and gains were chosen on the robot table's
# step responses (docs/measurements/policy-2026-11-27-position-actions.md): a 0.2 m slide settles in 0.08-0.2 s
# with 0-6 mm of overshoot, a half-turn in 0.14-0.18 s with 0.02-0.2 rad, and the rods end on their targets;
# a braking margin of 0.9 overshoots by 55 mm and 1.4-2.7 rad, and a proportional controller alone at 25-40 /s
# spins the rods.
BRAKING_MARGIN = 0.7
LEAD_S = 0.02
SLIDE_GAIN = 16.0    # 1/s
ROTATE_GAIN = 24.0   # 1/s


def action_mode_of(action_high) -> str:
    """A saved policy's action mode, read from the upper bound of its action box: the one place a trained
    model says which actions it emits (velocity 20, position 1)."""
    high = np.asarray(action_high, dtype=float).ravel()
    if high.size and np.allclose(high, ACTION_LIMIT):
        return "velocity"
    if high.size and np.allclose(high, POSITION_ACTION_LIMIT):
        return "position"
    raise ValueError(f"an action box bounded by {high.max() if high.size else 'nothing'} is neither velocities "
                     f"([-{ACTION_LIMIT:g}, {ACTION_LIMIT:g}]) nor position targets ([-1, 1])")


class PositionTargets:
    """Own-view position targets in [-1, 1]^8 -> the paper's own-view velocity action, one control step at a time.

    The targets' order is the command's: for each own rod (goalie, defence, midfield, attack) its slide, then
    its rotation. The controller reads the own rods' joints from the 36-D observation (their own encoders, not
    the camera), so it behaves the same in the env, in evaluation and in policy_node.
    """

    def __init__(self, params: dict, command_limits):
        geometry = own_rod_geometry(params)
        rods = params["rods"]
        self.scale = np.ravel([[geometry[rod].travel, np.pi] for rod in RODS])
        self.slots = np.array([OWN_SLOT[rod] for rod in RODS])
        self.limits = np.asarray(command_limits, dtype=float)
        self.jerk = np.tile([float(rods["slide_jerk_limit"]), float(rods["rotate_jerk_limit"])], len(RODS))
        self.acceleration = np.tile([float(rods["slide_acceleration_limit"]), float(rods["rotate_acceleration_limit"])], len(RODS))
        self.gain = np.tile([SLIDE_GAIN, ROTATE_GAIN], len(RODS))

    def targets(self, action) -> np.ndarray:
        """Slide targets in metres and rotation targets in radians (own view), command order."""
        return np.clip(np.asarray(action, dtype=float).ravel(), -POSITION_ACTION_LIMIT, POSITION_ACTION_LIMIT) * self.scale

    def velocity_action(self, obs, action) -> np.ndarray:
        rods = np.asarray(obs, dtype=float)[4:].reshape(8, 4)[self.slots]  # slide, slide velocity, angle, angular velocity
        position = rods[:, [0, 2]].ravel()
        velocity = rods[:, [1, 3]].ravel()
        error = self.targets(action) - (position + LEAD_S * velocity)
        distance = np.abs(error)
        speed = np.minimum.reduce([BRAKING_MARGIN * np.cbrt(self.jerk * distance * distance),
                                   np.sqrt(self.acceleration * distance), self.gain * distance])
        command = np.sign(error) * np.minimum(speed, self.limits)
        return (command / self.limits * ACTION_LIMIT).astype(np.float32)
