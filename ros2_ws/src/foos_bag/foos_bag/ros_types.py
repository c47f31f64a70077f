"""Small bridges between rclpy and rosbags: message classes by name and QoS conversion."""
from __future__ import annotations

import importlib

from rclpy.duration import Duration
from rclpy.qos import (
    DurabilityPolicy,
    HistoryPolicy,
    LivelinessPolicy,
    QoSProfile,
    ReliabilityPolicy,
)
from rosbags.interfaces import Qos, QosDurability, QosHistory, QosLiveliness, QosReliability, QosTime

# Deep enough that a recorder stalled for a second at 1 kHz still loses nothing.
RECORD_DEPTH = 1000


def message_class(msgtype: str):
    """The rclpy message class for 'pkg/msg/Name' (needed even for raw subscriptions), or None."""
    package, _, name = msgtype.partition("/msg/")
    if not name:
        return None
    try:
        return getattr(importlib.import_module(f"{package}.msg"), name)
    except (ImportError, AttributeError):
        return None


def _time(d: Duration) -> QosTime:
    ns = d.nanoseconds if isinstance(d, Duration) else 0
    # rclpy reports "infinite" as a huge value; rosbag2 stores it as 0x7fffffff/0xffffffff in the same way.
    sec, nsec = divmod(ns, 1_000_000_000)
    return QosTime(min(sec, 2147483647), nsec if sec < 2147483647 else 4294967295)


def to_bag_qos(profile: QoSProfile) -> Qos:
    """rclpy QoSProfile -> rosbags Qos (what rosbag2 stores as offered_qos_profiles)."""
    history = {HistoryPolicy.KEEP_LAST: QosHistory.KEEP_LAST, HistoryPolicy.KEEP_ALL: QosHistory.KEEP_ALL}
    reliability = {
        ReliabilityPolicy.RELIABLE: QosReliability.RELIABLE,
        ReliabilityPolicy.BEST_EFFORT: QosReliability.BEST_EFFORT,
    }
    durability = {
        DurabilityPolicy.VOLATILE: QosDurability.VOLATILE,
        DurabilityPolicy.TRANSIENT_LOCAL: QosDurability.TRANSIENT_LOCAL,
    }
    liveliness = {
        LivelinessPolicy.AUTOMATIC: QosLiveliness.AUTOMATIC,
        LivelinessPolicy.MANUAL_BY_TOPIC: QosLiveliness.MANUAL_BY_TOPIC,
    }
    return Qos(
        history.get(profile.history, QosHistory.UNKNOWN),
        int(profile.depth),
        reliability.get(profile.reliability, QosReliability.UNKNOWN),
        durability.get(profile.durability, QosDurability.UNKNOWN),
        _time(profile.deadline),
        _time(profile.lifespan),
        liveliness.get(profile.liveliness, QosLiveliness.UNKNOWN),
        _time(profile.liveliness_lease_duration),
        bool(profile.avoid_ros_namespace_conventions),
    )


def subscription_qos(publisher_profiles: list[QoSProfile]) -> QoSProfile:
    """A subscription QoS that matches every publisher: reliable only if all of them are, transient-local
    only if all of them are (the rule rosbag2's recorder follows)."""
    reliable = all(p.reliability == ReliabilityPolicy.RELIABLE for p in publisher_profiles)
    latched = bool(publisher_profiles) and all(
        p.durability == DurabilityPolicy.TRANSIENT_LOCAL for p in publisher_profiles
    )
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=RECORD_DEPTH,
        reliability=ReliabilityPolicy.RELIABLE if reliable else ReliabilityPolicy.BEST_EFFORT,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )


def publisher_qos(recorded: list[Qos]) -> QoSProfile:
    """A playback publisher QoS from the recorded offered profiles (reliable and volatile when unknown)."""
    best_effort = any(q.reliability == QosReliability.BEST_EFFORT for q in recorded)
    latched = bool(recorded) and all(q.durability == QosDurability.TRANSIENT_LOCAL for q in recorded)
    return QoSProfile(
        history=HistoryPolicy.KEEP_LAST,
        depth=RECORD_DEPTH,
        reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        durability=DurabilityPolicy.TRANSIENT_LOCAL if latched else DurabilityPolicy.VOLATILE,
    )
