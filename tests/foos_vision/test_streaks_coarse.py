"""The streak search's half-resolution pass (streaks.may_hold_streak: a big ball is looked for at half resolution
first, and at full resolution only where something may be a streak), and the connected components every search
labels its masks with (detection.components)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from foos_vision.detection import streaks
from foos_vision.detection.candidate_rules import STREAK_WIDTH
from foos_vision.detection.components import components_with_stats
from foos_vision.detection.streaks import find_streaks, may_hold_streak

from .test_streaks import FELT, RADIUS, SIZE, exposure, learned_colour, moving


def rod_and_figure(image: np.ndarray) -> np.ndarray:
    image[:, 150:158] = (120, 122, 125)  # a steel rod across the streak
    image[84:114, 144:164] = learned_colour().astype(np.uint8)  # a figure of the ball's colour beside it, on the rod
    return image


def search(image: np.ndarray, axes: bool = False) -> list:
    h, w = SIZE
    rod_axes = None
    if axes:
        rod_axes = np.zeros(SIZE, np.uint8)
        rod_axes[:, 154] = 255
    return find_streaks(image, (0, 0, w, h), lambda u, v: RADIUS, learned_colour(), FELT, width=STREAK_WIDTH,
                        rod_axes=rod_axes)


SCENES = {
    "long": lambda: exposure(moving((100.3, 100.0), (235.0, 124.6))),
    "diagonal": lambda: exposure(moving((250.0, 60.0), (170.5, 141.2))),
    "short": lambda: exposure(moving((100.0, 120.0), (124.0, 120.0))),
    "struck from rest": lambda: exposure(moving((80.0, 110.0), (180.0, 130.0), rest=0.4)),
    "by a figure of its colour": lambda: rod_and_figure(exposure(moving((100.0, 120.0), (230.0, 128.0)))),
}


@pytest.mark.parametrize("scene", sorted(SCENES))
def test_the_half_resolution_pass_keeps_every_streak_found_at_full_resolution(scene, monkeypatch):
    # The drawn ball (8 px) is below COARSE_RADIUS: searched at full resolution only, then with the pass forced.
    image = SCENES[scene]()
    axes = scene == "by a figure of its colour"
    full = search(image, axes)
    assert full, "no streak drawn"
    monkeypatch.setattr(streaks, "COARSE_RADIUS", 0.0)
    coarse_first = search(image, axes)
    assert [(s.u, s.v, s.motion) for s in coarse_first] == [(s.u, s.v, s.motion) for s in full]


def test_felt_and_a_ball_at_rest_are_not_searched_at_full_resolution(monkeypatch):
    h, w = SIZE
    for image in (exposure([np.array([-100.0, -100.0])]), exposure(moving((180.0, 120.0), (180.0, 120.0)))):
        assert not may_hold_streak(image, (0, 0, w, h), RADIUS, lambda u, v: RADIUS, learned_colour(), FELT,
                                   width=STREAK_WIDTH)
    monkeypatch.setattr(streaks, "COARSE_RADIUS", 0.0)
    assert search(exposure(moving((180.0, 120.0), (180.0, 120.0)))) == []


def test_components_are_those_of_opencvs_default():
    # Blobs and specks, a few to most of the pixels set. (The centroid of an empty background, label 0 of a mask
    # with every pixel set, is not compared: NaN in one, a number in the other.)
    rng = np.random.default_rng(3)
    for fill in (0.02, 0.2, 0.6):
        smooth = cv2.GaussianBlur(rng.random((240, 320)), (0, 0), 2)
        mask = ((smooth < np.quantile(smooth, fill)) | (rng.random(smooth.shape) < fill / 4)).astype(np.uint8) * 255
        ours, default = components_with_stats(mask), cv2.connectedComponentsWithStats(mask, connectivity=8)
        assert ours[0] == default[0] > 5
        assert np.array_equal(ours[1], default[1]) and np.array_equal(ours[2], default[2])
        assert np.array_equal(ours[3][1:], default[3][1:])
