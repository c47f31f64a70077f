"""still_ball: the felt and a ball lighter than it in one drawn frame, nothing else given."""
from __future__ import annotations

import math

import cv2
import numpy as np

from foos_vision.still_ball import StillBallFinder


def drawn_still(ball=(1200, 500), ball_bgr=(235, 235, 235)):
    """A 1920x1080 frame: grey floor, a green felt 1400 x 790 px (a 1.2 x 0.68 m field at 1160 px/m), white lines,
    dark figures' heads of the ball's size, and a ball (35 mm: 40.6 px across)."""
    frame = np.full((1080, 1920, 3), (90, 90, 90), np.uint8)
    cv2.rectangle(frame, (260, 145), (1660, 935), (60, 130, 50), -1)
    cv2.line(frame, (960, 145), (960, 935), (240, 240, 240), 6)
    cv2.circle(frame, (960, 540), 120, (240, 240, 240), 6)
    for u in (500, 700, 1400):
        cv2.circle(frame, (u, 300), 20, (30, 30, 30), -1)
    cv2.circle(frame, ball, 20, ball_bgr, -1, cv2.LINE_AA)
    return cv2.GaussianBlur(frame, (5, 5), 1.0)


def test_the_field_and_the_ball_are_found():
    field, candidates = StillBallFinder().find(drawn_still())
    assert field is not None and 0.4 < field.share < 0.7
    assert abs(field.ball_radius_px - 20.3) < 2.0, field.ball_radius_px
    assert candidates and math.hypot(candidates[0].u - 1200, candidates[0].v - 500) < 3.0, candidates[:2]


def test_a_yellow_ball_needs_no_colour_given():
    field, candidates = StillBallFinder().find(drawn_still(ball=(700, 800), ball_bgr=(40, 210, 230)))
    assert candidates and math.hypot(candidates[0].u - 700, candidates[0].v - 800) < 3.0, candidates[:2]


def test_no_felt_no_field():
    field, candidates = StillBallFinder().find(np.random.default_rng(1).integers(0, 255, (480, 640, 3), np.uint8))
    assert field is None and candidates == []
