"""What render_video --bag films, read from a bag: the ball and rod states and the measured ball, as the arrays
scenarios.StateReplay takes."""
from __future__ import annotations

from typing import NamedTuple, Optional

import numpy as np

from foos_bag import BagError, read_ball_detections, read_ball_states, read_joint_states, topics
from foos_core.joints import joint_order, take_joints
from foos_core.names import BALL_DETECTION_TOPIC, BALL_STATE_TOPIC, JOINT_STATES_TOPIC

from .errors import RenderError


class RecordedStates(NamedTuple):
    """What render_video --bag films (scenarios.StateReplay's input): the ball states, the rod joint states and the
    measured ball, each None where the bag lacks it (but never both ball topics)."""

    t: Optional[np.ndarray]  # (N,) s, stamps of /ball/state
    ball_position: Optional[np.ndarray]  # (N, 3)
    ball_velocity: Optional[np.ndarray]  # (N, 3)
    joint_t: Optional[np.ndarray] = None  # (M,) s, stamps of /joint_states
    joint_position: Optional[np.ndarray] = None  # (M, 16) in JOINT_NAMES order; 0 for a joint the bag lacks
    detection_t: Optional[np.ndarray] = None  # (K,) s, capture stamps of /ball/detection
    detection_position: Optional[np.ndarray] = None  # (K, 3), table frame

    @property
    def _ball_t(self) -> np.ndarray:
        return self.t if self.t is not None else self.detection_t

    @property
    def start(self) -> float:
        """Time 0 of the video: the first ball state (the first detection where there is none)."""
        return float(self._ball_t[0])

    @property
    def end(self) -> float:
        return float(self._ball_t[-1])


def _read_or_none(reader, bag: str, topic: str, available: dict):
    """A topic's arrays, or None where the bag has no such topic or no message on it."""
    if available.get(topic, ("", 0))[1] == 0:
        return None
    try:
        return reader(bag)
    except (BagError, OSError, ValueError) as error:
        raise RenderError(f"{bag}: {error}") from None


def read_recorded_states(bag: str) -> RecordedStates:
    """The ball and rod states and the measured ball that render_video --bag films; RenderError (one line) when the
    bag has no ball to film."""
    try:
        available = topics(bag)
    except (BagError, OSError, ValueError) as error:
        raise RenderError(f"--bag {bag}: {error}") from None
    balls = _read_or_none(read_ball_states, bag, BALL_STATE_TOPIC, available)
    detections = _read_or_none(read_ball_detections, bag, BALL_DETECTION_TOPIC, available)
    joints = _read_or_none(read_joint_states, bag, JOINT_STATES_TOPIC, available)
    if balls is None and detections is None:
        raise RenderError(f"{bag}: no ball to render: the bag has no {BALL_STATE_TOPIC} or {BALL_DETECTION_TOPIC} messages "
                          f"(topics: {', '.join(sorted(available)) or 'none'})")
    if detections is not None and detections.frame_id not in ("table", ""):
        raise RenderError(f"{bag}: {BALL_DETECTION_TOPIC} is in frame `{detections.frame_id}`, not `table`")
    for name, arrays in ((BALL_STATE_TOPIC, balls), (BALL_DETECTION_TOPIC, detections)):
        if arrays is not None and len(arrays.t) < 2:
            raise RenderError(f"{bag}: fewer than 2 {name} messages, nothing to render")
    recorded = RecordedStates(None, None, None)
    if balls is not None:
        recorded = recorded._replace(t=balls.t, ball_position=np.asarray(balls.position), ball_velocity=np.asarray(balls.velocity))
    if detections is not None:
        recorded = recorded._replace(detection_t=np.asarray(detections.t), detection_position=np.asarray(detections.position))
    if joints is not None:
        position = take_joints(joints.position, joint_order(joints.names, allow_missing=True), fill=0.0)
        recorded = recorded._replace(joint_t=np.asarray(joints.t), joint_position=position)
    return recorded
