"""A bag's topics as numpy arrays, sorted by stamp (what evaluation, calibration and the vision tests read).

    det = read_ball_detections("run1")     # BallDetections(t, position, frame_id), sorted by t
    js = read_joint_states("run1")         # JointStates(t, names, position, velocity, effort)
"""
from __future__ import annotations

from pathlib import Path
from typing import NamedTuple

import numpy as np

from foos_core.joints import joint_order, take_joints
from foos_core.names import (
    BALL_DETECTION_TOPIC,
    BALL_STATE_TOPIC,
    COMMAND_SIZE,
    GOAL_TOPIC,
    JOINT_STATES_TOPIC,
    TEAMS,
    command_topic,
)
from foos_core.stamps import stamp_to_seconds

from .errors import BagError
from .reader import messages

__all__ = [
    "BallDetections", "BallStates", "Commands", "JointStates",
    "read_ball_detections", "read_ball_states", "read_commands", "read_goals", "read_joint_states",
]


class BallDetections(NamedTuple):
    t: np.ndarray  # (N,) capture stamps, s, sorted
    position: np.ndarray  # (N, 3) m, in frame_id
    frame_id: str


class BallStates(NamedTuple):
    t: np.ndarray  # (N,) header stamps, s, sorted
    position: np.ndarray  # (N, 3) m
    velocity: np.ndarray  # (N, 3) m/s


class JointStates(NamedTuple):
    t: np.ndarray  # (N,) header stamps, s, sorted
    names: list[str]  # J joint names, the column order of the arrays
    position: np.ndarray  # (N, J)
    velocity: np.ndarray  # (N, J), NaN where not published
    effort: np.ndarray  # (N, J), NaN where not published


class Commands(NamedTuple):
    t: np.ndarray  # (N,) receive times, s (Float64MultiArray has no header)
    values: np.ndarray  # (N, 8)


def _need(n: int, path: str | Path, topic: str) -> None:
    if n == 0:
        raise BagError(f"{path}: topic {topic} has no messages")


def read_ball_detections(path: str | Path, topic: str = BALL_DETECTION_TOPIC) -> BallDetections:
    """Ball detections: header (capture) stamps in s sorted, positions (N,3) and the frame."""
    t, p, frames = [], [], set()
    for _, _, msg in messages(path, [topic]):
        t.append(stamp_to_seconds(msg.header.stamp))
        p.append((msg.point.x, msg.point.y, msg.point.z))
        frames.add(msg.header.frame_id)
    _need(len(t), path, topic)
    if len(frames) > 1:
        raise BagError(f"{path}: {topic} mixes frames {sorted(frames)}; expected one")
    order = np.argsort(np.asarray(t), kind="stable")
    return BallDetections(np.asarray(t)[order], np.asarray(p, dtype=np.float64)[order], frames.pop())


def read_ball_states(path: str | Path, topic: str = BALL_STATE_TOPIC) -> BallStates:
    """Ball states from nav_msgs/Odometry: stamps in s sorted, positions and linear velocities (N,3)."""
    t, p, v = [], [], []
    for _, _, msg in messages(path, [topic]):
        t.append(stamp_to_seconds(msg.header.stamp))
        q, w = msg.pose.pose.position, msg.twist.twist.linear
        p.append((q.x, q.y, q.z))
        v.append((w.x, w.y, w.z))
    _need(len(t), path, topic)
    order = np.argsort(np.asarray(t), kind="stable")
    return BallStates(np.asarray(t)[order], np.asarray(p, dtype=np.float64)[order], np.asarray(v, dtype=np.float64)[order])


def _joint_values(msg, names: list[str]) -> np.ndarray:
    """(3, J): a JointState's positions, velocities and efforts in the order of `names`; NaN for a joint the
    message lacks and for values it leaves out (velocity and effort may be empty or shorter than its names)."""
    n = len(msg.name)
    if n == 0:  # nothing to reorder (and take_joints needs values to index)
        return np.full((3, len(names)), np.nan)
    values = np.full((3, n), np.nan)
    for row, given in zip(values, (msg.position, msg.velocity, msg.effort)):
        m = min(n, len(given))
        row[:m] = given[:m]
    return take_joints(values, joint_order(msg.name, wanted=names, allow_missing=True))


def read_joint_states(path: str | Path, topic: str = JOINT_STATES_TOPIC) -> JointStates:
    """Joint states as (N, J) arrays, columns in the order of the first message's names.

    Messages that list the joints in another order are reordered by name; a joint missing from a message,
    or a message without velocity/effort, gives NaN there.
    """
    t: list[float] = []
    rows: list[np.ndarray] = []
    names: list[str] | None = None
    for _, _, msg in messages(path, [topic]):
        if names is None:
            names = list(msg.name)
        rows.append(_joint_values(msg, names))
        t.append(stamp_to_seconds(msg.header.stamp))
    _need(len(t), path, topic)
    order = np.argsort(np.asarray(t), kind="stable")
    values = np.asarray(rows)[order]  # (N, 3, J)
    position, velocity, effort = (np.ascontiguousarray(values[:, k]) for k in range(3))
    return JointStates(np.asarray(t)[order], names or [], position, velocity, effort)


def read_commands(path: str | Path, team: str) -> Commands:
    """Rod commands of `team` ('home' or 'away'): receive times in s and the (N, 8) target velocities."""
    if team not in TEAMS:
        raise BagError(f"team must be 'home' or 'away', not {team!r}")
    topic = command_topic(team)
    t, values = [], []
    for _, stamp, msg in messages(path, [topic]):
        data = np.asarray(msg.data, dtype=np.float64)
        if data.shape != (COMMAND_SIZE,):
            raise BagError(f"{path}: a {topic} message holds {data.size} values, expected {COMMAND_SIZE}")
        t.append(stamp * 1e-9)
        values.append(data)
    _need(len(t), path, topic)
    return Commands(np.asarray(t), np.asarray(values))


def read_goals(path: str | Path, topic: str = GOAL_TOPIC) -> tuple[np.ndarray, list[str]]:
    """Goals: receive times in s and the scoring team per goal. A bag without goals gives empty arrays
    only if it has the topic; a bag without the topic is a BagError."""
    t, teams = [], []
    for _, stamp, msg in messages(path, [topic]):
        t.append(stamp * 1e-9)
        teams.append(msg.data)
    return np.asarray(t, dtype=np.float64), teams

