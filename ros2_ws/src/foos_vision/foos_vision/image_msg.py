"""sensor_msgs/Image to a BGR array for the tracker (no cv_bridge needed)."""
from __future__ import annotations

import cv2
import numpy as np


def image_to_bgr(msg) -> np.ndarray:
    """sensor_msgs/Image (bgr8, rgb8, mono8) to a BGR array."""
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
