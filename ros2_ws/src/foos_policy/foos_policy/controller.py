"""The ROS-free core of policy_node: table-frame state in, one team's rod command out.

It maps /joint_states (any joint order, by name) onto the contract's 16 joints, builds the team's
own-view observation (mirrored for the away team), runs the policy, maps the action back onto the
team's table-frame command, and decides when inputs are too old to act on.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np

from foos_core.joints import joint_order, take_joints
from foos_core.names import COMMAND_SIZE, JOINT_NAMES, TEAMS

from .observation import action_to_command, observe
from .policies import Policy


class StateError(ValueError):
    """A state message the controller cannot use (missing joints, NaN); one line for the user."""


@dataclass
class JointSample:
    stamp: float
    positions: np.ndarray   # JOINT_NAMES order
    velocities: np.ndarray


@dataclass
class BallSample:
    stamp: float
    position: np.ndarray
    velocity: np.ndarray


def joint_sample(stamp: float, names: Sequence[str], positions: Sequence[float], velocities: Sequence[float]) -> JointSample:
    """Reorder a JointState's arrays into JOINT_NAMES order; missing velocities count as zero."""
    order = joint_order(names, allow_missing=True)
    missing = missing_joints(order)
    if missing:
        raise StateError(f"/joint_states lacks {len(missing)} of the {len(JOINT_NAMES)} rod joints (e.g. {missing[0]})")
    if len(positions) != len(names):
        raise StateError("/joint_states has a different number of names and positions")
    q = take_joints(positions, order)
    dq = take_joints(velocities, order) if len(velocities) == len(names) else np.zeros(len(JOINT_NAMES))
    if not (np.all(np.isfinite(q)) and np.all(np.isfinite(dq))):
        raise StateError("/joint_states holds NaN or infinite values")
    return JointSample(stamp, q, dq)


def missing_joints(order: np.ndarray) -> list[str]:
    """The rod joints that joint_order(..., allow_missing=True) did not find, in JOINT_NAMES order."""
    return [JOINT_NAMES[i] for i in np.flatnonzero(order < 0)]


def ball_sample(stamp: float, position: Sequence[float], velocity: Sequence[float]) -> BallSample:
    p = np.asarray(position, dtype=float)
    v = np.asarray(velocity, dtype=float)
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
        raise StateError("/ball/state holds NaN or infinite values")
    return BallSample(stamp, p, v)


# A camera loop's /ball/state is stamped with the frame's time, so it arrives already old: a 30-60 fps camera
# plus 20-80 ms from image to detection (the simulated camera loop under load) delivers states 0.05-0.12 s old,
# and 0.1 s held the rods 8 times in a 53 s tracker-fed game. 0.25 s lets two frames be missed before the rods
# stop; a ball the tracker has lost for longer holds them.
STALE_AFTER_S = 0.25


class PolicyController:
    """One team's controller. `step(now)` returns (command, reason): the command to publish, and why
    the rods are held (None when the policy acted)."""

    def __init__(self, policy: Policy, team: str, command_limits, stale_after: float = STALE_AFTER_S):
        if team not in TEAMS:
            raise ValueError(f"team must be one of {TEAMS}, got `{team}`")
        self.policy = policy
        self.team = team
        self.limits = np.asarray(command_limits, dtype=float)
        self.stale_after = float(stale_after)
        self.joints: Optional[JointSample] = None
        self.ball: Optional[BallSample] = None
        self.latencies: list[float] = []

    def hold(self) -> np.ndarray:
        """Rods held: zero target velocities keep every rod where it is."""
        return np.zeros(COMMAND_SIZE)

    def stale_reason(self, now: float) -> Optional[str]:
        for what, sample in (("/joint_states", self.joints), ("/ball/state", self.ball)):
            if sample is None:
                return f"no {what} received yet"
            age = now - sample.stamp
            if age > self.stale_after:
                return f"{what} is {age:.2f} s old (stale after {self.stale_after:g} s)"
        return None

    def step(self, now: float) -> tuple[np.ndarray, Optional[str]]:
        reason = self.stale_reason(now)
        if reason is not None:
            return self.hold(), reason
        obs = observe(self.team, self.ball.position, self.ball.velocity, self.joints.positions, self.joints.velocities)
        start = time.perf_counter()
        action = self.policy.predict(obs)
        self.latencies.append(time.perf_counter() - start)
        return action_to_command(self.team, action, self.limits), None

    def latency_stats(self) -> dict[str, float]:
        """Inference latency over the calls since the last report, in milliseconds; resets the window."""
        if not self.latencies:
            return {}
        ms = np.array(self.latencies) * 1e3
        self.latencies = []
        return {"n": int(ms.size), "median_ms": float(np.median(ms)), "p95_ms": float(np.percentile(ms, 95)), "max_ms": float(ms.max())}
