"""Figures of the ball's colour without joint states, as a user meets them: render_video --home-color and
--away-color, then track_video. Seen from the side, an orange figure's legs below its rod are a round orange blob
of the ball's size beside the rod, not over it; they must neither start nor carry a track."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from foos_bag import read_ball_detections
from foos_core.table_params import REFERENCE_PARAMS_FILE
from foos_sim.camera.render import read_truth
from foos_vision.video_io import VideoReader

from .helpers import render, ros2_run


def orange_pixels(bgr: np.ndarray) -> int:
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    return int(np.count_nonzero((hsv[..., 0] >= 5) & (hsv[..., 0] <= 20) & (hsv[..., 1] >= 150) & (hsv[..., 2] >= 80)))


def first_frame(video) -> np.ndarray:
    reader = VideoReader(str(video))
    _, _, frame = next(reader.frames())
    reader.close()
    return frame


@pytest.mark.timeout(300)
def test_an_oblique_camera_does_not_take_orange_figures_for_an_orange_ball(tmp_path):
    # The scene is played on the 20 kHz reference, where it was chosen: on the default fast physics seed 4 plays
    # another game, in which the tracker found 84 % of the half-visible frames (the same-colour weakness that
    # bench_vision measures and docs/vision.md reports), under this check's 90 %.
    video = render(tmp_path / "same.mp4", "--camera", "oblique", "--width", "640", "--height", "480", "--fps", "60",
                   "--ball-color", "orange", "--home-color", "orange", "--away-color", "black", "--duration", "2.5",
                   "--seed", "4", "--hide-every", "1.0", "--hide-for", "0.3", "--visibility",
                   "--params-file", str(REFERENCE_PARAMS_FILE), timeout=240)
    stem = video.with_suffix("").as_posix()
    # The same first frame with foos_sim's red and blue figures has far fewer pixels of the ball's colour.
    default = render(tmp_path / "default.mp4", "--camera", "oblique", "--width", "640", "--height", "480",
                     "--ball-color", "orange", "--duration", "0.01", "--seed", "4")
    assert orange_pixels(first_frame(video)) > orange_pixels(first_frame(default)) + 500
    bag = tmp_path / "bag"
    result = ros2_run("track_video", str(video), "--markers", f"{stem}.markers.yaml", "--out", str(bag),
                      "--ball-color", "orange", "--quiet")
    assert result.returncode == 0, result.stderr
    truth = read_truth(f"{stem}.truth.csv")
    detections = read_ball_detections(bag)
    frames = np.round(detections.t * 60).astype(int)
    assert not np.any(np.isnan(truth["x"][frames])), "a detection while the ball was picked up: a figure"
    error = np.hypot(detections.position[:, 0] - truth["x"][frames], detections.position[:, 1] - truth["y"][frames])
    assert error.max() < 0.010, f"a detection {error.max() * 1000:.0f} mm from the ball: a figure"
    half_visible = np.nonzero(truth["visible"] >= 0.5)[0]
    assert np.isin(half_visible, frames).mean() >= 0.9


def test_a_figure_colour_that_is_not_one_is_a_one_line_error(tmp_path):
    result = ros2_run("render_video", str(tmp_path / "x.mp4"), "--home-color", "purple", "--quiet")
    assert result.returncode != 0
    lines = [line for line in result.stderr.splitlines() if line.strip()]
    assert "purple" in lines[-1] and "R,G,B" in lines[-1]
    assert not (tmp_path / "x.mp4").exists()
