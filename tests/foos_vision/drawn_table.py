"""Drawn frames of a table seen straight from above, with real ArUco tags: exact truth without a render."""
from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np

from foos_core.markers import MarkerLayout, load_markers

SCALE = 400.0  # px per m: u = 319.5 + SCALE * y, v = 239.5 + SCALE * x (a camera straight above)
FELT_BGR = (40, 140, 30)
ORANGE_BGR = (20, 120, 250)
STEEL_BGR = (170, 170, 170)
FPS = 120.0
TAGS = {0: (-0.40, -0.68), 1: (0.40, -0.68), 2: (0.40, 0.0), 3: (-0.40, 0.0), 4: (0.40, 0.68), 5: (-0.40, 0.68)}
RADIUS_PX = 0.0175 * SCALE


def to_pixel(x: float, y: float, scale: float = SCALE) -> tuple[float, float]:
    """Pixel-centre coordinates (pixel (0, 0) covers -0.5..0.5), as OpenCV measures them."""
    return 319.5 + scale * y, 239.5 + scale * x


def write_layout(path: Path, tag_size: float = 0.06) -> MarkerLayout:
    """The markers file of the drawn tags (at ball-centre height, so no parallax); tag_size in m."""
    lines = ["dictionary: DICT_4X4_50", f"size: {tag_size}", "markers:"]
    lines += [f"  {i}: [{x}, {y}, 0.0175]" for i, (x, y) in TAGS.items()]
    path.write_text("\n".join(lines) + "\n")
    return load_markers(path)


def table_frame(scale: float = SCALE, tag_px: int = int(0.06 * SCALE), border: int = 6) -> np.ndarray:
    """The felt and the tags, drawn at `scale` px per m with tags of tag_px px (and a white border)."""
    frame = np.zeros((480, 640, 3), np.uint8)
    frame[:] = FELT_BGR
    dictionary = cv2.aruco.getPredefinedDictionary(cv2.aruco.DICT_4X4_50)
    for tag_id, (x, y) in TAGS.items():
        u, v = to_pixel(x, y, scale)
        tag = cv2.cvtColor(cv2.aruco.generateImageMarker(dictionary, tag_id, tag_px), cv2.COLOR_GRAY2BGR)
        tag = cv2.copyMakeBorder(tag, border, border, border, border, cv2.BORDER_CONSTANT, value=(255, 255, 255))
        u0, v0 = int(round(u - (tag.shape[1] - 1) / 2)), int(round(v - (tag.shape[0] - 1) / 2))
        frame[v0:v0 + tag.shape[0], u0:u0 + tag.shape[1]] = tag
    return frame


def draw_ball(frame: np.ndarray, x: float, y: float, bgr=ORANGE_BGR, scale: float = SCALE,
              thickness: int = -1) -> None:
    """A ball drawn with sub-pixel centre and an anti-aliased edge, like a camera's (thickness > 0: only its
    outline, as a figure's hollow outline of the ball's colour looks)."""
    u, v = to_pixel(x, y, scale)
    cv2.circle(frame, (int(round(u * 4)), int(round(v * 4))), int(round(0.0175 * scale * 4)), bgr, thickness,
               cv2.LINE_AA, shift=2)
