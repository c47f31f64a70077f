"""A fisheye camera end to end: render_video through cv2.fisheye (the shipped `fisheye` camera, like the
issue's real clip, at half its size), then track_video with the intrinsics render_video wrote, against the
truth; and without them, a clear refusal."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from foos_sim.camera.render import read_truth

from .helpers import render, ros2_run

FPS = 25.0


@pytest.fixture(scope="module")
def fisheye_video(tmp_path_factory):
    out = tmp_path_factory.mktemp("fisheye") / "fisheye.mp4"
    return render(out, "--camera", "fisheye", "--width", "960", "--height", "540", "--duration", "1.2",
                  "--ball-color", "yellow", "--visibility", "--seed", "5")


@pytest.mark.timeout(120)
def test_fisheye_video_is_tracked_with_its_intrinsics(fisheye_video, tmp_path):
    stem = fisheye_video.with_suffix("")
    camera = yaml.safe_load(open(f"{stem}.camera.yaml"))
    assert camera["model"] == "fisheye" and camera["intrinsics"]["model"] == "fisheye"
    assert len(camera["intrinsics"]["dist_coeffs"]) == 4
    csv = tmp_path / "m.csv"
    result = ros2_run("track_video", str(fisheye_video), "--markers", f"{stem}.markers.yaml", "--intrinsics",
                      f"{stem}.camera.yaml", "--out", str(tmp_path / "bag"), "--csv-metres", str(csv), "--quiet")
    assert result.returncode == 0, result.stderr
    truth = read_truth(f"{stem}.truth.csv")
    found = np.genfromtxt(csv, delimiter=",", names=True)
    frames = np.round(found["t"] * FPS).astype(int)
    in_view = np.nonzero(np.nan_to_num(truth["visible"]) >= 0.5)[0]
    assert len(in_view) > 20
    assert np.isin(in_view, frames).mean() >= 0.9, result.stdout
    errors = np.hypot(found["x"] - truth["x"][frames], found["y"] - truth["y"][frames]) * 1000
    assert np.median(errors) < 2.0 and np.percentile(errors, 95) < 5.0, errors


@pytest.mark.timeout(60)
def test_fisheye_video_without_intrinsics_is_refused_with_a_hint(fisheye_video, tmp_path):
    stem = fisheye_video.with_suffix("")
    result = ros2_run("track_video", str(fisheye_video), "--markers", f"{stem}.markers.yaml",
                      "--out", str(tmp_path / "bag"), "--quiet")
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "--intrinsics" in result.stderr, result.stderr
