"""The paper's 36-D observation and 8-D action, seen from either team (ROS-free).

Observation (own view): ball x, y, vx, vy, then for each of the 8 rods ordered from the own goal to the
opponent's goal: slide, slide velocity, rotation (wrapped to [-pi, pi)), rotation velocity.

The away team is served by mirroring: its view is the table turned by 180 degrees about z, so x, y and
both joint axes change sign, and its own rods take the home rods' slots. One policy then plays either
side, and the paper's home-team policy is the same function with no mirroring.
"""
from __future__ import annotations

import numpy as np

from foos_core.names import AXES, COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS

OBS_SIZE = 36
ACTION_LIMIT = 20.0  # the paper's action box [-20, 20]^8

# Rod slots from the home goal (y = -0.525) to the away goal (y = +0.525): (owner, rod).
ROD_SLOTS: tuple[tuple[str, str], ...] = (
    ("own", "goalie"), ("own", "defence"), ("opponent", "attack"), ("own", "midfield"),
    ("opponent", "midfield"), ("own", "attack"), ("opponent", "defence"), ("opponent", "goalie"),
)
# Slot of each own rod in the observation (own goalie is slot 0, own attack slot 5).
OWN_SLOT = {rod: i for i, (owner, rod) in enumerate(ROD_SLOTS) if owner == "own"}


def other_team(team: str) -> str:
    return "away" if team == "home" else "home"


def _joint_index(team: str, rod: str, axis: str) -> int:
    return TEAMS.index(team) * COMMAND_SIZE + RODS.index(rod) * len(AXES) + AXES.index(axis)


def _slot_indices(team: str) -> tuple[np.ndarray, np.ndarray]:
    """Indices into the 16 joints (JOINT_NAMES order) of each slot's slide and rotate joints."""
    slides, rotates = [], []
    for owner, rod in ROD_SLOTS:
        t = team if owner == "own" else other_team(team)
        slides.append(_joint_index(t, rod, "slide"))
        rotates.append(_joint_index(t, rod, "rotate"))
    return np.array(slides), np.array(rotates)


_SLOTS = {team: _slot_indices(team) for team in TEAMS}
assert len(JOINT_NAMES) == 2 * COMMAND_SIZE


def wrap_angle(angle: np.ndarray) -> np.ndarray:
    return (np.asarray(angle) + np.pi) % (2 * np.pi) - np.pi


def observe(team: str, ball_position, ball_velocity, joint_positions, joint_velocities) -> np.ndarray:
    """The 36-D observation of `team` from table-frame state (16 joints in JOINT_NAMES order)."""
    sign = 1.0 if team == "home" else -1.0
    slides, rotates = _SLOTS[team]
    q = np.asarray(joint_positions, dtype=float)
    dq = np.asarray(joint_velocities, dtype=float)
    obs = np.empty(OBS_SIZE, dtype=np.float32)
    obs[0:2] = sign * np.asarray(ball_position, dtype=float)[:2]
    obs[2:4] = sign * np.asarray(ball_velocity, dtype=float)[:2]
    rods = obs[4:].reshape(8, 4)
    rods[:, 0] = sign * q[slides]
    rods[:, 1] = sign * dq[slides]
    rods[:, 2] = wrap_angle(sign * q[rotates])
    rods[:, 3] = sign * dq[rotates]
    return obs


# A learner's view of the observation: each quantity divided by a typical size, so that no input dominates a
# small network's first layer. Raw, the rods' angular velocities reach 314 rad/s on the robot drives (and 40 on the
# former servos) beside ball positions of 0.6 m. Tried because SAC's actor on the raw view emitted corrections at
# 0.7 of their bounds (pre-tanh means of about 1 in median, a fifth above 2): with the scaled view it still does
# (docs/measurements/policy-2026-11-28-scaled.md), so the inputs' sizes were not what kept it from learning.
# Clipped at +-OBS_SCALED_BOUND, so a model's observation box tells scaled (finite bounds) from raw (unbounded)
# observations, as its action box tells the action mode; the scales themselves are saved with the model
# (`observation_scale`) and checked when it is loaded.
BALL_POSITION_SCALE = 0.6    # m, half the field's length
BALL_SPEED_SCALE = 5.0       # m/s, a firm pass
SLIDE_SCALE = 0.1            # m, about a rod's travel each way
SLIDE_SPEED_SCALE = 3.5      # m/s, the robot's slide drives
ANGLE_SCALE = np.pi          # rad, the wrapped angle's range
SPIN_SCALE = 100.0           # rad/s, a kick's rotation speed
OBS_SCALED_BOUND = 5.0
OBS_SCALE = np.concatenate([[BALL_POSITION_SCALE] * 2, [BALL_SPEED_SCALE] * 2,
                            np.tile([SLIDE_SCALE, SLIDE_SPEED_SCALE, ANGLE_SCALE, SPIN_SCALE], 8)]).astype(np.float32)
assert OBS_SCALE.shape == (OBS_SIZE,)


def scaled_observation(obs) -> np.ndarray:
    """The learner's view of a 36-D observation (or a batch of them): sizes of about 1, clipped."""
    return np.clip(np.asarray(obs, np.float32) / OBS_SCALE, -OBS_SCALED_BOUND, OBS_SCALED_BOUND)  # float32 throughout


def observes_scaled(observation_space) -> bool:
    """Whether a saved model's observation box is the scaled view's (finite bounds) rather than the raw one's."""
    high = np.asarray(observation_space.high, dtype=float)
    if np.all(np.isinf(high)):
        return False
    if np.allclose(high, OBS_SCALED_BOUND):
        return True
    raise ValueError(f"observation box bounds {high.max():g} are neither raw (unbounded) nor scaled ({OBS_SCALED_BOUND:g})")


def action_to_command(team: str, action, command_limits: np.ndarray) -> np.ndarray:
    """An own-view action in [-20, 20]^8 as the team's table-frame rod command (contract layout)."""
    a = np.clip(np.asarray(action, dtype=float).ravel(), -ACTION_LIMIT, ACTION_LIMIT)
    sign = 1.0 if team == "home" else -1.0
    return sign * a / ACTION_LIMIT * np.asarray(command_limits, dtype=float)


def command_to_action(team: str, command, command_limits: np.ndarray) -> np.ndarray:
    sign = 1.0 if team == "home" else -1.0
    return sign * np.asarray(command, dtype=float) / np.asarray(command_limits, dtype=float) * ACTION_LIMIT
