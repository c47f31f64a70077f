"""The ball detector on drawn frames: the hue band sees the shaded half of a ball, and the disc
measures (fill, spill) tell a ball from a figure's outline or a ball merged with something."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from foos_vision.detection.detector import BallDetector, colour_model

FELT_BGR = (40, 140, 30)
ORANGE_BGR = (20, 120, 250)
RADIUS = 9.0


def _frame(draw) -> np.ndarray:
    frame = np.zeros((120, 160, 3), np.uint8)
    frame[:] = FELT_BGR
    draw(frame)
    return cv2.GaussianBlur(frame, (3, 3), 0.7)


def _shaded_ball(frame: np.ndarray, centre=(80.3, 60.6), shade: float = 0.4) -> None:
    """A ball lit from above: its lower half at `shade` of the lit colour (same hue and saturation)."""
    ys, xs = np.mgrid[0:frame.shape[0], 0:frame.shape[1]]
    inside = (xs - centre[0]) ** 2 + (ys - centre[1]) ** 2 <= RADIUS**2
    lit = np.array(ORANGE_BGR, float)
    frame[inside & (ys <= centre[1])] = lit
    frame[inside & (ys > centre[1])] = (lit * shade).astype(np.uint8)


def _candidates(frame: np.ndarray, use_band: bool):
    detector = BallDetector(colour_model("orange"))
    found, _, _ = detector.candidates(frame, (0, 0, frame.shape[1], frame.shape[0]), lambda u, v: RADIUS, RADIUS,
                                      use_band=use_band)
    return found


def test_hue_band_sees_the_whole_shaded_ball():
    frame = _frame(_shaded_ball)
    box_only = _candidates(frame, use_band=False)
    with_band = _candidates(frame, use_band=True)
    assert len(box_only) == 1 and len(with_band) == 1
    # The colour box sees the lit half only: half a ball, which the tracker trusts only near a track.
    assert box_only[0].area_ratio < 0.65 and box_only[0].roundness < 0.65
    assert with_band[0].area_ratio > 0.85 and with_band[0].roundness > 0.9 and with_band[0].fill > 0.9
    assert abs(with_band[0].u - 80.3) < 0.5 and abs(with_band[0].v - 60.6) < 0.5


def test_band_adds_nothing_for_a_white_ball():
    assert colour_model("white").band_mask(np.full((4, 4, 3), 200, np.uint8)) is None


@pytest.mark.parametrize("colour, bgr", [("red", (20, 20, 200)), ("orange", ORANGE_BGR), ("yellow", (20, 200, 230))])
def test_hue_bands_keep_the_ball_colours_apart(colour, bgr):
    pixel = np.array([[bgr]], np.uint8)
    others = [name for name in ("red", "orange", "yellow") if name != colour]
    assert colour_model(colour).band_mask(pixel)[0, 0] == 255
    assert all(colour_model(name).band_mask(pixel)[0, 0] == 0 for name in others)
    felt = np.array([[FELT_BGR]], np.uint8)
    assert colour_model(colour).band_mask(felt)[0, 0] == 0


def test_fill_and_spill_tell_a_ball_from_an_outline_and_a_merged_blob():
    ball = _candidates(_frame(lambda f: _shaded_ball(f, shade=1.0)), use_band=True)[0]
    assert ball.fill > 0.9 and ball.spill < 0.05
    # The outline of a figure whose edge pixels blend into the ball's hue: ball-sized, but hollow.
    ring = _candidates(_frame(lambda f: cv2.circle(f, (80, 60), int(RADIUS), ORANGE_BGR, 3)), use_band=True)[0]
    assert ring.fill < 0.4
    # A ball against a bar of its colour: the blob goes on past the ball's outline.
    merged = _candidates(_frame(lambda f: (_shaded_ball(f, shade=1.0),
                                           cv2.rectangle(f, (88, 40), (110, 80), ORANGE_BGR, -1))), use_band=True)
    assert merged and max(c.spill for c in merged) > 0.15


def test_ball_touching_a_bar_of_its_colour_keeps_its_centre():
    def draw(frame):
        _shaded_ball(frame, shade=1.0)
        cv2.rectangle(frame, (88, 30), (100, 90), ORANGE_BGR, -1)  # a figure's body against it

    frame = _frame(draw)
    found = _candidates(frame, use_band=True)
    ball = min(found, key=lambda c: abs(c.u - 80.3) + abs(c.v - 60.6))
    # The centroid of the ball-coloured pixels around the ball is pulled toward the bar; the fit of the
    # outline's circular part much less. (Not so for a bar thinner than a third of the ball hugging its
    # edge: there both are about 2 px off; see docs/vision.md.)
    mask = colour_model("orange").mask(cv2.cvtColor(frame, cv2.COLOR_BGR2Lab), frame)
    ys, xs = np.nonzero(mask)
    near = (xs - 80.3) ** 2 + (ys - 60.6) ** 2 <= (1.3 * RADIUS) ** 2
    centroid_error = np.hypot(xs[near].mean() - 80.3, ys[near].mean() - 60.6)
    fit_error = np.hypot(ball.u - 80.3, ball.v - 60.6)
    assert ball.spill > 0.15 and fit_error < 1.0 and fit_error < 0.7 * centroid_error, (fit_error, centroid_error)
