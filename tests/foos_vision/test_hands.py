"""render_video --hands: a skin-coloured hand reaches in, covers the ball while it is picked up, and leaves;
the tracker, which knows nothing of hands, takes no part of it for the ball."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_bag import read_ball_detections
from foos_sim.camera.render import read_truth

from .helpers import render, ros2_run


def skin_mask(frame: np.ndarray) -> np.ndarray:
    """Pixels of a lit skin tone (OpenCV HSV): warm hue, moderate saturation, bright. The felt, the rods, the
    figures and the yellow ball are outside this box; the wooden frame is not, so it is taken out below."""
    hsv = cv2.cvtColor(frame, cv2.COLOR_BGR2HSV)
    return cv2.inRange(hsv, (4, 40, 150), (20, 140, 255))


@pytest.mark.timeout(150)
def test_a_hand_picks_the_ball_up_and_is_not_taken_for_it(tmp_path):
    video = render(tmp_path / "hands.mp4", "--width", "480", "--height", "360", "--fps", "30", "--duration", "1.5",
                   "--ball-color", "yellow", "--hide-every", "1.0", "--hide-for", "0.25", "--hands", "--visibility",
                   "--seed", "5")
    truth = read_truth(tmp_path / "hands.truth.csv")
    capture = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        frames.append(frame)
    capture.release()
    assert len(frames) == len(truth["t"]) == 46
    # Skin-toned pixels where the first frame (no hand yet) has none: the wood of the table frame stays put.
    wood = cv2.dilate(skin_mask(frames[0]), np.ones((5, 5), np.uint8))
    skin = np.array([np.count_nonzero(skin_mask(f) & ~wood) for f in frames])
    hidden = np.isnan(truth["x"])
    assert hidden.any() and not hidden[:30].any()
    # No hand until it reaches in (0.2 s before the pick-up at 1 s), a hand over the field while the ball is
    # out of sight, and none once it has gone back out (0.2 s after the ball is put down at 1.25 s; the next
    # pick-up is at least 0.7 s after the first). Noise and moving figures give a few dozen pixels.
    assert np.all(skin[:23] < 100), skin
    assert np.all(skin[hidden] > 300), skin
    assert skin[-1] < 100, skin
    # The hand covers the ball just before it is lifted and just after it is put down: there the ball is
    # on the table but not in view.
    covered = (~hidden) & (truth["visible"] == 0)
    assert covered.any(), truth["visible"]

    bag = tmp_path / "bag"
    result = ros2_run("track_video", str(video), "--markers", str(tmp_path / "hands.markers.yaml"), "--out", str(bag),
                      "--ball-color", "yellow", "--quiet")
    assert result.returncode == 0, result.stderr
    detections = read_ball_detections(bag)
    fps = 30.0
    by_frame = {int(round(t * fps)): (x, y) for t, (x, y) in zip(detections.t, detections.position[:, :2])}
    in_view = truth["visible"] >= 0.5
    assert sum(k in by_frame for k in np.nonzero(in_view)[0]) >= 0.9 * in_view.sum()
    for k, (x, y) in by_frame.items():
        # Nothing where the ball is out of sight (the hand holds it), and every detection is the ball.
        assert truth["visible"][k] > 0, (k, x, y)
        assert math.hypot(x - truth["x"][k], y - truth["y"][k]) < 0.01, (k, x, y)


def test_hands_need_a_pick_up(tmp_path):
    result = ros2_run("render_video", str(tmp_path / "x.mp4"), "--hands", "--quiet")
    assert result.returncode == 2
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert "--hide-every" in result.stderr
    assert not (tmp_path / "x.mp4").exists()
