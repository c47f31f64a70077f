"""What a policy's action asks of the rods: the paper's velocities, position targets, or corrections to the
scripted controller (ROS-free).

- `velocity`: the paper's action box [-20, 20]^8, each entry a share of its drive's command limit (the
  contract's velocity command, scaled).
- `position`: [-1, 1]^8, per own rod a slide target (a share of the rod's travel either side of centre) and
  a rotation target (a share of pi, 0 = figures hanging down). At each control step a braking-curve
  controller (PositionTargets) turns the targets into the paper's velocity action, so policy_node, the bag
  and the contract still carry velocity commands, and evaluation and play use one code path.
- `residual`: corrections to the scripted controller (foos_policy.scripted, the baseline that tracks the
  ball and kicks): per own rod an offset of the slide target it holds, in metres (at most 40 mm), and the
  angle it holds the figures at when not kicking, in radians (at most a quarter turn), held on the position
  targets' braking curve (ScriptedResidual). An action of zero plays the scripted controller's tracking and
  kicks with that steadier hold.

Why position targets: a robot table's rods (TU Darmstadt's, Jaykixx/Foosball) are driven to positions by
their own jerk-limited servo loop. On those drives a velocity action is hard to learn with: a constant action
spins a rod or runs it into its stop, and a random one flails, so own goals come from the home rods sweeping
the ball back. A constant position action holds the rods in place as a wall, and a kick is a target flipped
from behind the ball to beyond it.
"""
from __future__ import annotations

import numpy as np

from foos_core.names import COMMAND_SIZE, RODS

from .observation import ACTION_LIMIT, OWN_SLOT, wrap_angle
from .scripted import RESIDUAL_BASES, ScriptedPolicy, lift_ahead_angles, own_rod_geometry
from .scripted import SLIDE_GAIN as SCRIPTED_SLIDE_GAIN

ACTION_MODES = ("velocity", "position", "residual")
POSITION_ACTION_LIMIT = 1.0

# Why corrections to the scripted controller: the velocity policies learned to whirl their rods (about 300
# turns an episode, 89-91 % of their touches spun; docs/measurements/policy-2026-11-28-spins.md), so half
# their goals would not count and their own blocks turn into own goals, and position targets learned too little
# in the budget. A correction starts from the scripted controller's play (it tracks the ball and kicks) and can
# aim, time and place it: it moves the targets the scripted controller holds each rod at, its slide by up to
# 40 mm (where a figure meets the ball, so which way the ball goes) and its figures' angle by up to a quarter
# turn (a block's posture, a back-swing before the kick).
# The held angle is followed on the braking curve of the position targets, not with the scripted controller's
# 25 /s proportional hold: on the jerk-limited drives that hold overshoots a step of a quarter turn by 100 % and
# one of a half turn past the half turn, where it pushes the rod round (measured: a step from +pi/2 to -pi/2
# turned the figures a full turn more). A velocity added to the hold instead (up to a fifth of the rotation
# limit) spun the rods 107-134 turns an episode when held at either bound.
RESIDUAL_SLIDE_OFFSET = 0.04          # m
RESIDUAL_ROTATE_OFFSET = np.pi / 2    # rad
RESIDUAL_ACTION_HIGH = np.tile([RESIDUAL_SLIDE_OFFSET, RESIDUAL_ROTATE_OFFSET], len(RODS))

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


def action_high(mode: str) -> np.ndarray:
    """The upper bound of the 8-D action box of an action mode (the box is symmetric)."""
    if mode == "velocity":
        return np.full(COMMAND_SIZE, ACTION_LIMIT)
    if mode == "position":
        return np.full(COMMAND_SIZE, POSITION_ACTION_LIMIT)
    if mode == "residual":
        return RESIDUAL_ACTION_HIGH.copy()
    raise ValueError(f"action must be one of {', '.join(ACTION_MODES)}, got '{mode}'")


def action_mode_of(action_high_saved) -> str:
    """A saved policy's action mode, read from the upper bound of its action box: the one place a trained
    model says which actions it emits (velocity 20, position 1, residual 0.04 m / pi/2 per slide / rotation)."""
    high = np.asarray(action_high_saved, dtype=float).ravel()
    for mode in ACTION_MODES:
        if high.size == COMMAND_SIZE and np.allclose(high, action_high(mode)):
            return mode
    raise ValueError(f"an action box bounded by {high.max() if high.size else 'nothing'} is neither velocities "
                     f"([-{ACTION_LIMIT:g}, {ACTION_LIMIT:g}]), position targets ([-1, 1]) nor corrections to the "
                     f"scripted controller's targets ({RESIDUAL_SLIDE_OFFSET:g} m, {RESIDUAL_ROTATE_OFFSET:.4g} rad)")


def action_map(mode: str, params: dict, command_limits, residual_base: str = "scripted"):
    """What turns an action of `mode` into the paper's velocity action at each control step (an object with
    `velocity_action(obs, action)`), or None where the action is that already. `residual_base` is what corrections
    act on (RESIDUAL_BASES)."""
    if mode == "position":
        return PositionTargets(params, command_limits)
    if mode == "residual":
        return ScriptedResidual(params, command_limits, residual_base)
    action_high(mode)  # an unknown mode is refused here
    return None


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
        command = np.sign(error) * np.minimum(self.braking_speed(np.abs(error)), self.limits)
        return (command / self.limits * ACTION_LIMIT).astype(np.float32)

    def braking_speed(self, distance: np.ndarray) -> np.ndarray:
        """Per axis (command order), the speed to command toward a target `distance` away (the braking curve)."""
        return np.minimum.reduce([BRAKING_MARGIN * np.cbrt(self.jerk * distance * distance),
                                  np.sqrt(self.acceleration * distance), self.gain * distance])


class ScriptedResidual:
    """Target offsets (metres, radians) -> the scripted controller's velocity action with its targets moved by
    them, one control step at a time, from the same own-view observation the policy acts on (the ball as the
    camera loop delivers it, the own rods from their encoders). A slide follows its moved target with the
    scripted controller's gain; a rod's figures are held at the offset angle on the braking curve
    (PositionTargets), except while the scripted controller kicks with it. On the `lift-ahead` base the angle
    offsets add to the lift-ahead rule's angles."""

    def __init__(self, params: dict, command_limits, base: str = "scripted"):
        if base not in RESIDUAL_BASES:
            raise ValueError(f"the residual base must be one of {', '.join(RESIDUAL_BASES)}, got '{base}'")
        self.base = base
        self.scripted = ScriptedPolicy(params, command_limits)
        self.rod_y = np.array([g.y for g in (self.scripted.geometry[rod] for rod in RODS)])
        self.hold = PositionTargets(params, command_limits)
        self.limits = np.asarray(command_limits, dtype=float)
        self.slots = np.array([OWN_SLOT[rod] for rod in RODS])

    def velocity_action(self, obs, action) -> np.ndarray:
        offset = np.clip(np.asarray(action, dtype=float).ravel(), -RESIDUAL_ACTION_HIGH, RESIDUAL_ACTION_HIGH)
        command, kicking = self.scripted.plan(obs)
        command[0::2] += SCRIPTED_SLIDE_GAIN * offset[0::2]
        rods = np.asarray(obs, dtype=float)[4:].reshape(8, 4)[self.slots]
        held = offset[1::2] + lift_ahead_angles(obs, self.rod_y) if self.base == "lift-ahead" else offset[1::2]
        error = wrap_angle(held - (rods[:, 2] + LEAD_S * rods[:, 3]))  # the short way round
        # braking_speed takes a distance per axis in command order; the rotations' entries are the odd ones
        hold = np.sign(error) * self.hold.braking_speed(np.repeat(np.abs(error), 2))[1::2]
        command[1::2] = np.where(kicking, command[1::2], hold)
        command = np.clip(command, -self.limits, self.limits)
        return (command / self.limits * ACTION_LIMIT).astype(np.float32)
