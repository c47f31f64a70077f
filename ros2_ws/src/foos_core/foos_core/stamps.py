"""ROS time stamps (`builtin_interfaces/Time` or anything with `sec` and `nanosec`) to and from seconds."""
from __future__ import annotations


def stamp_to_seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def seconds_to_stamp(seconds: float, stamp_type):
    """A stamp of `stamp_type` (rounded to the nanosecond; negative seconds borrow from `sec`)."""
    ns = int(round(seconds * 1e9))
    return stamp_type(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)
