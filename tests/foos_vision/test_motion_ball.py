"""motion_ball: the ball's colour where the table changed, on frames drawn here with real OpenCV."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_vision.detection.motion_ball import MotionMap
from foos_vision.tracking.tracker import BallTracker, TrackerConfig

from .drawn_table import FPS, draw_ball, table_frame, write_layout

FELT = (60, 120, 40)  # BGR green felt
YELLOW = (40, 200, 220)
RED = (40, 40, 200)
RADIUS = 10.0  # px


def table(noise_seed: int) -> np.ndarray:
    rng = np.random.default_rng(noise_seed)
    frame = np.empty((240, 320, 3), np.uint8)
    frame[:] = FELT
    return np.clip(frame + rng.normal(0, 3, frame.shape), 0, 255).astype(np.uint8)


def learned(map_: MotionMap, frames: int = 20) -> None:
    for k in range(frames):
        map_.look(table(k), (0, 0, 320, 240))


def test_a_ball_that_appears_is_one_blob_of_one_disc():
    motion = MotionMap()
    learned(motion)
    frame = table(99)
    cv2.circle(frame, (200, 120), int(RADIUS), YELLOW, -1, cv2.LINE_AA)
    motion.look(frame, (0, 0, 320, 240))
    blobs = motion.blobs(np.array(YELLOW, float), lambda u, v: RADIUS)
    assert len(blobs) == 1
    assert math.hypot(blobs[0].u - 200, blobs[0].v - 120) < 1.0
    assert 0.7 <= blobs[0].shares <= 1.3 and blobs[0].roundness > 0.8


def test_a_streak_is_found_at_its_middle():
    motion = MotionMap()
    learned(motion)
    # A ball moved 4 radii during the exposure: the mean of its positions, each a share of the frame.
    exposure = np.zeros((240, 320, 3), np.float32)
    steps = 16
    for s in range(steps):
        frame = table(100).astype(np.float32)
        cv2.circle(frame, (int(round(120 + 40 * s / (steps - 1))), 100), int(RADIUS), YELLOW, -1, cv2.LINE_AA)
        exposure += frame / steps
    motion.look(exposure.astype(np.uint8), (0, 0, 320, 240))
    blobs = motion.blobs(np.array(YELLOW, float), lambda u, v: RADIUS)
    assert len(blobs) == 1 and math.hypot(blobs[0].u - 140, blobs[0].v - 100) < 2.0, blobs
    assert 0.6 <= blobs[0].shares <= 1.4 and blobs[0].roundness < 0.7


def test_a_figure_of_another_colour_and_a_flicker_are_not_the_ball():
    motion = MotionMap()
    learned(motion)
    frame = table(101)
    cv2.rectangle(frame, (100, 80), (118, 130), RED, -1)  # a red figure swung into view
    frame = cv2.convertScaleAbs(frame, alpha=1.15)  # the lights flicker
    motion.look(frame, (0, 0, 320, 240))
    assert motion.blobs(np.array(YELLOW, float), lambda u, v: RADIUS) == []


def test_a_ball_resting_becomes_table_and_the_window_bounds_the_search():
    motion = MotionMap()
    learned(motion)
    for k in range(120):
        frame = table(200 + k)
        cv2.circle(frame, (60, 60), int(RADIUS), YELLOW, -1, cv2.LINE_AA)
        cv2.circle(frame, (250, 180), int(RADIUS), YELLOW, -1, cv2.LINE_AA) if k == 119 else None
        motion.look(frame, (0, 0, 320, 240))
    everywhere = motion.blobs(np.array(YELLOW, float), lambda u, v: RADIUS)
    assert [(round(b.u), round(b.v)) for b in everywhere] == [(250, 180)]
    assert motion.blobs(np.array(YELLOW, float), lambda u, v: RADIUS, np.array([60.0, 60.0]), 40.0) == []


@pytest.mark.timeout(120)
def test_a_ball_of_no_prototype_colour_is_learned_from_its_motion_and_tracked(tmp_path):
    # A yellow-green ball (Lab a 78, b 198, hue 44: outside the yellow prototype's box and hue band) rolling over
    # the drawn table: auto settles on no prototype, learns the moving ball's colour, then tracks it.
    layout = write_layout(tmp_path / "markers.yaml")
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto"))
    lime = (60, 230, 150)
    found, settled_at = [], None
    for k in range(160):
        x, y = -0.25 + 0.5 * k / 160, -0.55 + 1.1 * k / 160
        frame = table_frame()
        draw_ball(frame, x, y, lime)
        detection = tracker.process(cv2.GaussianBlur(frame, (3, 3), 0.7), k / FPS)
        if tracker.colour_settled and settled_at is None:
            settled_at = k
        if detection is not None:
            found.append(math.hypot(detection.x - x, detection.y - y))
    assert tracker.colour.name == "learned", tracker.colour
    assert settled_at is not None and len(found) >= 0.9 * (160 - settled_at - 1), (settled_at, len(found))
    assert max(found) < 0.003, max(found)
