"""Small conversions between ROS messages and numpy shared by the nodes (no cv_bridge needed)."""
from __future__ import annotations

import numpy as np


def stamp_to_seconds(stamp) -> float:
    return stamp.sec + stamp.nanosec * 1e-9


def seconds_to_stamp(seconds: float, stamp_type):
    ns = int(round(seconds * 1e9))
    return stamp_type(sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def image_to_bgr(msg) -> np.ndarray:
    """sensor_msgs/Image (bgr8, rgb8, mono8) to a BGR array."""
    import cv2

    channels = {"bgr8": 3, "rgb8": 3, "mono8": 1}.get(msg.encoding)
    if channels is None:
        raise ValueError(f"unsupported image encoding `{msg.encoding}` (bgr8, rgb8, mono8)")
    data = np.frombuffer(bytes(msg.data) if not isinstance(msg.data, (bytes, bytearray)) else msg.data, np.uint8)
    rows = data.reshape(msg.height, msg.step)[:, : msg.width * channels]
    image = rows.reshape(msg.height, msg.width, channels) if channels == 3 else rows.reshape(msg.height, msg.width)
    if msg.encoding == "rgb8":
        return cv2.cvtColor(image, cv2.COLOR_RGB2BGR)
    if msg.encoding == "mono8":
        return cv2.cvtColor(image, cv2.COLOR_GRAY2BGR)
    return image
