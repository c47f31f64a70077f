"""TagLocator.locate: a refit looks for the tags only around where they were (the camera is mounted), and in the whole
frame when that cannot be trusted. Drawn frames with real ArUco tags (drawn_table)."""
from __future__ import annotations

import cv2
import numpy as np

from foos_vision.camera import geometry
from foos_vision.camera.geometry import Lens, TagLocator

from .drawn_table import TAGS, table_frame


class CountingLocator(TagLocator):
    """Counts its whole-frame detections."""

    def __init__(self, layout):
        super().__init__(layout, Lens(None))
        self.whole = 0

    def detect(self, gray):
        self.whole += 1
        return super().detect(gray)


def _shifted(frame: np.ndarray, dx: float, dy: float) -> np.ndarray:
    """The frame moved by (dx, dy) px (sub-pixel: the tags' corners move by a fraction of a pixel), felt filled in."""
    m = np.float32([[1, 0, dx], [0, 1, dy]])
    return cv2.warpAffine(frame, m, (frame.shape[1], frame.shape[0]), flags=cv2.INTER_LINEAR,
                          borderMode=cv2.BORDER_REPLICATE)


def test_crops_find_the_tags_the_whole_frame_finds(layout):
    locator, whole = CountingLocator(layout), TagLocator(layout, Lens(None))
    base = table_frame()
    for k, (dx, dy) in enumerate([(0, 0), (0.3, -0.2), (0.7, 0.4), (-0.5, 0.9), (1.5, -1.0)]):
        frame = _shifted(base, dx, dy)
        centres, corners = locator.locate(frame)
        expected_centres, expected = whole.detect(cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY))
        assert sorted(corners) == sorted(expected) == sorted(TAGS), k
        for tag_id in expected:
            assert np.abs(corners[tag_id] - expected[tag_id]).max() < 0.01, (k, tag_id)
            assert np.abs(centres[tag_id] - expected_centres[tag_id]).max() < 0.01, (k, tag_id)
    assert locator.whole == 1  # the first frame only: every tag was then found in its crop


def test_a_tag_that_moved_out_of_its_crop_sends_it_back_to_the_whole_frame(layout):
    locator = CountingLocator(layout)
    base = table_frame()
    locator.locate(base)
    moved = _shifted(base, 0, -45)  # twice a tag's side: no tag is in its crop any more
    _, corners = locator.locate(moved)
    assert locator.whole == 2
    assert sorted(corners) == sorted(TAGS)
    _, corners = locator.locate(moved)  # and from there on, its crops again
    assert locator.whole == 2 and sorted(corners) == sorted(TAGS)


def test_a_tag_hidden_at_the_start_is_looked_for_in_the_whole_frame_again(layout):
    locator = CountingLocator(layout)
    base = table_frame()
    hidden = base.copy()
    hidden[60:100, 25:75] = (40, 140, 30)  # tag 0 under a hand (felt-coloured here)
    _, corners = locator.locate(hidden)
    assert 0 not in corners and locator.whole == 1
    seen = []
    for _ in range(geometry.TAG_WHOLE_EVERY + 1):
        _, corners = locator.locate(base)
        seen.append(0 in corners)
    # The crops look for the tags the whole frame showed; after TAG_WHOLE_EVERY calls the whole frame shows tag 0.
    assert not any(seen[:geometry.TAG_WHOLE_EVERY]) and seen[-1]
    assert locator.whole == 2
