"""The detection stage alone, given where to look (drawn frames, real ArUco tags, real OpenCV): BallSearch.near
reads a SearchWindow, the track's position and its uncertainty, with no Kalman filter behind it."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_vision.detection.ball_search import SearchWindow
from foos_vision.tracking.tracker import BallTracker, TrackerConfig, search_window
from foos_vision.tracking.velocity import KalmanState

from .drawn_table import draw_ball, table_frame, to_pixel

BALL = (0.05, 0.1)


def drawn(x: float, y: float) -> np.ndarray:
    frame = table_frame()
    draw_ball(frame, x, y)
    return cv2.GaussianBlur(frame, (3, 3), 0.7)


@pytest.fixture
def search(layout):
    """The searches of a tracker that has fitted the tags on one frame (the field as the camera sees it)."""
    tracker = BallTracker(layout, TrackerConfig(ball_color="orange"))
    assert tracker.process(drawn(-0.2, -0.3), 0.0) is not None
    return tracker.search


def window(x: float, y: float, std: float = 0.002) -> SearchWindow:
    return SearchWindow(0.01, np.array([x, y]), std**2 * np.eye(2))


@pytest.mark.timeout(60)
def test_a_window_over_the_ball_finds_it_and_one_elsewhere_does_not(search):
    frame = drawn(*BALL)
    found, _, _ = search.near(frame, window(BALL[0] + 0.004, BALL[1] - 0.004))
    u, v = to_pixel(*BALL)
    assert found is not None and math.hypot(found.u - u, found.v - v) < 1.0
    assert search.near(frame, window(-0.3, 0.4))[0] is None


def test_the_window_is_the_filters_position_and_its_covariance():
    p = np.arange(16.0).reshape(4, 4)
    w = search_window(KalmanState(1.5, np.array([0.1, -0.2, 3.0, 4.0]), p))
    assert w.t == 1.5 and w.position.tolist() == [0.1, -0.2] and w.covariance.tolist() == [[0.0, 1.0], [4.0, 5.0]]
