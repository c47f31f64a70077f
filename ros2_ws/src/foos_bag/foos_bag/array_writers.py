"""Numpy arrays into a bag, as the messages a live system would have published (offline producers: the
sim, the video tracker, the calibration generator).

    with BagWriter("run1") as bag:
        write_ball_detections(bag, t, xyz, latency=0.02)   # header stamp = t, receive time = t + latency
"""
from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from foos_core.names import (
    BALL_DETECTION_TOPIC,
    BALL_FRAME,
    BALL_STATE_TOPIC,
    JOINT_STATES_TOPIC,
    TABLE_FRAME,
)

from .errors import BagError
from .message_types import JOINT_STATE, ODOMETRY, POINT_STAMPED, header, typestore
from .writer import BagWriter

__all__ = ["write_ball_detections", "write_ball_states", "write_joint_states"]


def _as_times(t: Any, what: str) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(t)):
        raise BagError(f"{what}: times contain NaN or infinity")
    if np.any(t < 0):
        raise BagError(f"{what}: times must be >= 0 s (a bag stores unsigned nanoseconds)")
    return t


def _as_rows(a: Any, n: int, width: int | None, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and width is None:
        a = a.reshape(n, -1) if n else a.reshape(0, 0)
    if a.ndim != 2 or a.shape[0] != n or (width is not None and a.shape[1] != width):
        want = f"({n}, {width})" if width is not None else f"({n}, J)"
        raise BagError(f"{what}: expected an array of shape {want}, got {a.shape}")
    return a


def _write_sorted(writer: BagWriter, topic: str, receive: np.ndarray, cdrs: list) -> None:
    """Write in receive-time order, the order a recorder would have seen the messages in."""
    for i in np.argsort(receive, kind="stable"):
        writer.write_raw(topic, int(round(receive[i] * 1e9)), cdrs[i])


def write_ball_detections(
    writer: BagWriter,
    t: Any,
    position: Any,
    frame_id: str = TABLE_FRAME,
    topic: str = BALL_DETECTION_TOPIC,
    latency: Any = 0.0,
) -> None:
    """Ball detections as geometry_msgs/PointStamped: header stamp = t (capture), receive time = t + latency.

    `latency` is a number or an array like `t` (per-detection latency, s, >= 0).
    """
    t = _as_times(t, topic)
    position = _as_rows(position, len(t), 3, f"{topic} position")
    if not np.all(np.isfinite(position)):
        raise BagError(f"{topic}: positions contain NaN or infinity (drop missed detections instead)")
    latency = np.broadcast_to(np.asarray(latency, dtype=np.float64), t.shape)
    if not np.all(np.isfinite(latency)) or np.any(latency < 0):
        raise BagError(f"{topic}: latency must be finite and >= 0 s")
    writer.add_topic(topic, POINT_STAMPED)
    store = typestore()
    point_stamped, point = store.types[POINT_STAMPED], store.types["geometry_msgs/msg/Point"]
    cdrs = [
        store.serialize_cdr(point_stamped(header=header(ti, frame_id), point=point(x=p[0], y=p[1], z=p[2])), POINT_STAMPED)
        for ti, p in zip(t.tolist(), position.tolist())
    ]
    _write_sorted(writer, topic, t + latency, cdrs)


def write_ball_states(writer: BagWriter, t: Any, position: Any, velocity: Any, topic: str = BALL_STATE_TOPIC) -> None:
    """Ball states as nav_msgs/Odometry (frame `table`, child `ball`), received at their stamp."""
    t = _as_times(t, topic)
    position = _as_rows(position, len(t), 3, f"{topic} position")
    velocity = _as_rows(velocity, len(t), 3, f"{topic} velocity")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        raise BagError(f"{topic}: positions or velocities contain NaN or infinity")
    writer.add_topic(topic, ODOMETRY)
    store = typestore()
    T = store.types
    cov = np.zeros(36)
    cdrs = []
    for ti, p, v in zip(t.tolist(), position.tolist(), velocity.tolist()):
        msg = T[ODOMETRY](
            header=header(ti, TABLE_FRAME),
            child_frame_id=BALL_FRAME,
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                ),
                covariance=cov,
            ),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2]),
                    angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                ),
                covariance=cov,
            ),
        )
        cdrs.append(store.serialize_cdr(msg, ODOMETRY))
    _write_sorted(writer, topic, t, cdrs)


def write_joint_states(
    writer: BagWriter, t: Any, names: Sequence[str], position: Any, velocity: Any, topic: str = JOINT_STATES_TOPIC
) -> None:
    """Joint states as sensor_msgs/JointState (no effort), received at their stamp."""
    t = _as_times(t, topic)
    names = [str(n) for n in names]
    position = _as_rows(position, len(t), len(names), f"{topic} position")
    velocity = _as_rows(velocity, len(t), len(names), f"{topic} velocity")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        raise BagError(f"{topic}: positions or velocities contain NaN or infinity")
    writer.add_topic(topic, JOINT_STATE)
    store = typestore()
    empty = np.zeros(0)
    cdrs = [
        store.serialize_cdr(
            store.types[JOINT_STATE](header=header(ti, ""), name=names, position=p, velocity=v, effort=empty),
            JOINT_STATE,
        )
        for ti, p, v in zip(t.tolist(), position, velocity)
    ]
    _write_sorted(writer, topic, t, cdrs)
