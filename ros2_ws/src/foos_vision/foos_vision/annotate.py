"""What the tracker saw: tags, the homography grid on the ball plane, the rods' axes as placed on the steel seen
(a rod not found is not drawn), the ball and its recent track."""
from __future__ import annotations

from collections import deque

import cv2
import numpy as np

from .tracking.tracker import BallTracker, Detection


class Annotator:
    def __init__(self, tracker: BallTracker, trail: int = 60):
        self.tracker = tracker
        self.trail: deque = deque(maxlen=trail)

    def draw(self, frame: np.ndarray, detection: Detection | None) -> np.ndarray:
        out = frame.copy()
        tr = self.tracker
        for tag_id, quad in tr.last_tag_corners.items():
            colour = (0, 255, 0) if tag_id in tr.layout.positions else (0, 0, 255)
            cv2.polylines(out, [np.round(quad).astype(np.int32)], True, colour, 1, cv2.LINE_AA)
            cv2.putText(out, str(tag_id), tuple(int(v) for v in quad[0]), cv2.FONT_HERSHEY_SIMPLEX, 0.45, colour, 1)
        if tr.mapping is not None:
            half_x, half_y = tr.view.table.half_width, tr.view.table.half_length
            for x in np.linspace(-half_x, half_x, 7):  # six columns across, 10 cm rows along
                self._line(out, [(x, -half_y), (x, half_y)])
            for y in np.arange(-half_y, half_y + 1e-9, 0.1):
                self._line(out, [(-half_x, y), (half_x, y)])
        if tr.rod_axes is not None:
            out[tr.rod_axes > 0] = (255, 0, 255)
        if detection is not None:
            self.trail.append((detection.u, detection.v))
            radius = max(3, int(round(tr.view.radius_at_pixel(detection.u, detection.v))))
            cv2.circle(out, (int(round(detection.u)), int(round(detection.v))), radius + 2, (0, 0, 255), 1, cv2.LINE_AA)
            cv2.putText(out, f"({detection.x:+.3f}, {detection.y:+.3f}) m", (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.5,
                        (255, 255, 255), 1, cv2.LINE_AA)
        if len(self.trail) > 1:
            cv2.polylines(out, [np.round(np.array(self.trail)).astype(np.int32)], False, (0, 200, 255), 1, cv2.LINE_AA)
        return out

    def _line(self, image: np.ndarray, ends) -> None:
        a, b = np.array(ends[0], float), np.array(ends[1], float)
        points = np.array([a + s * (b - a) for s in np.linspace(0, 1, 20)])
        pixels = self.tracker.lens.distort(self.tracker.mapping.to_image(points))
        cv2.polylines(image, [np.round(pixels).astype(np.int32)], False, (255, 255, 0), 1, cv2.LINE_AA)
