"""What the commands read from bags, as the arrays the algorithms take: the rod joint states that pose the
figure mask (track_video --joint-states) and the ball and rod states a render replays (render_video --bag)."""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from foos_bag import BagError, read_ball_states, read_joint_states, topics
from foos_core.joints import joint_order, take_joints
from foos_core.names import BALL_STATE_TOPIC, JOINT_STATES_TOPIC

from .figure_mask import JointStatesError, JointTrack, joint_track


def read_joint_track(bag: str) -> JointTrack:
    """The /joint_states of a bag as a JointTrack; JointStatesError with one line when the bag cannot give it."""
    source = f"--joint-states {bag}"
    try:
        available = topics(bag)
    except (BagError, OSError, ValueError) as error:
        raise JointStatesError(f"{source}: {error}") from None
    if JOINT_STATES_TOPIC not in available:
        raise JointStatesError(f"{source}: the bag has no {JOINT_STATES_TOPIC} topic "
                               f"(topics: {', '.join(sorted(available)) or 'none'})")
    try:
        states = read_joint_states(bag)
    except (BagError, OSError, ValueError) as error:
        raise JointStatesError(f"{source}: {error}") from None
    return joint_track(states.t, list(states.names), states.position, source)


class RecordedStates(NamedTuple):
    """A bag's ball states and, where it has them, its rod joint states (scenarios.StateReplay's arguments)."""

    t: np.ndarray  # (N,) s, stamps of /ball/state
    ball_position: np.ndarray  # (N, 3)
    ball_velocity: np.ndarray  # (N, 3)
    joint_t: Optional[np.ndarray] = None  # (M,) s, stamps of /joint_states; None when the bag has none
    joint_position: Optional[np.ndarray] = None  # (M, 16) in JOINT_NAMES order; 0 for a joint the bag lacks


def read_recorded_states(bag: str) -> RecordedStates:
    """The ball and rod states render_video --bag films (ValueError when there are too few ball states)."""
    balls = read_ball_states(bag)
    if len(balls.t) < 2:
        raise ValueError(f"{bag}: fewer than 2 {BALL_STATE_TOPIC} messages, nothing to render")
    try:
        joints = read_joint_states(bag)
    except BagError:  # no /joint_states: the rods stay as the model has them
        return RecordedStates(balls.t, np.asarray(balls.position), np.asarray(balls.velocity))
    position = take_joints(joints.position, joint_order(joints.names, allow_missing=True), fill=0.0)
    return RecordedStates(balls.t, np.asarray(balls.position), np.asarray(balls.velocity), np.asarray(joints.t), position)
