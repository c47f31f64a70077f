"""Auto colour on drawn frames: a red figure that passes for a moving ball now and then must not win
over an orange ball that is hidden while the colour is being chosen."""
from __future__ import annotations

import cv2
import pytest

from drawn_table import FPS, draw_ball, table_frame, write_layout
from foos_vision.tracker import BallTracker, TrackerConfig

RED_BGR = (30, 30, 200)


@pytest.mark.timeout(60)
def test_a_figure_seen_now_and_then_does_not_settle_the_colour(tmp_path):
    layout = write_layout(tmp_path / "markers.yaml")
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto"))
    settled_at = None
    for k in range(120):
        frame = table_frame()
        if k % 5 == 0:
            # A red figure, sliding with its rod, that looks like a ball in one frame of five.
            draw_ball(frame, -0.2 + 0.004 * k, 0.075, RED_BGR)
        if k >= 40:
            draw_ball(frame, 0.1, -0.3 + 0.5 * (k - 40) / FPS)  # the orange ball, in view from frame 40
        tracker.process(cv2.GaussianBlur(frame, (3, 3), 0.7), k / FPS)
        if tracker._auto_done and settled_at is None:
            settled_at = k
            assert tracker.colour.name == "orange", (k, tracker.colour.name)
    assert settled_at is not None and settled_at >= 40
