"""render_video -> track_video as a user runs them: accuracy against the truth, stamps, outputs, bad input."""
from __future__ import annotations

import shutil

import cv2
import numpy as np
import pytest
import yaml

from foos_bag import read_ball_detections, read_ball_states, topics
from foos_sim.camera.render import read_truth

from .helpers import render, ros2_run


def truth_of(video):
    return read_truth(video.with_suffix("").as_posix() + ".truth.csv")


def markers_of(video):
    return video.with_suffix("").as_posix() + ".markers.yaml"


def test_render_writes_video_truth_camera_and_markers(overhead_video):
    truth = truth_of(overhead_video)
    assert len(truth["t"]) == 73  # 1.2 s at 60 fps, frames 0..72
    assert np.allclose(np.diff(truth["t"]), 1 / 60)
    hidden = np.isnan(truth["x"])
    assert 10 <= hidden.sum() <= 30  # picked up for 0.3 s of 1.2 s
    assert np.all(truth["visible"][hidden] == 0)
    assert np.all(np.abs(truth["x"][~hidden]) <= 0.34) and np.all(np.abs(truth["y"][~hidden]) <= 0.72)


@pytest.mark.timeout(120)
def test_track_video_matches_truth_and_stamps_frames(overhead_video, tmp_path):
    bag = tmp_path / "bag"
    result = ros2_run("track_video", str(overhead_video), "--markers", markers_of(overhead_video), "--out", str(bag),
                      "--start-time", "100.0", "--csv-pixels", str(tmp_path / "px.csv"),
                      "--csv-metres", str(tmp_path / "m.csv"), "--annotate", str(tmp_path / "seen.png"), "--quiet")
    assert result.returncode == 0, result.stderr
    assert "colour yellow" in result.stdout  # auto picked the ball's colour
    truth = truth_of(overhead_video)
    detections = read_ball_detections(bag)
    frames = np.round((detections.t - 100.0) * 60).astype(int)
    assert np.allclose(detections.t, 100.0 + frames / 60, atol=1e-6)  # stamp = start time + index / fps
    assert not np.any(np.isnan(truth["x"][frames])), "a detection in a frame where the ball was picked up"
    error = np.hypot(detections.position[:, 0] - truth["x"][frames], detections.position[:, 1] - truth["y"][frames])
    assert np.median(error) < 0.003
    assert np.percentile(error, 90) < 0.008
    half_visible = np.nonzero(truth["visible"] >= 0.5)[0]
    assert np.isin(half_visible, frames).mean() >= 0.9
    assert np.allclose(detections.position[:, 2], 0.0175)
    states = read_ball_states(bag)
    assert len(states.t) == len(detections.t) and np.all(np.isfinite(states.velocity))
    assert set(topics(bag)) >= {"/ball/detection", "/ball/state"}
    px = np.loadtxt(tmp_path / "px.csv", delimiter=",", skiprows=1)
    metres = np.loadtxt(tmp_path / "m.csv", delimiter=",", skiprows=1)
    assert px.shape == (len(frames), 3) and metres.shape == (len(frames), 5)
    assert (tmp_path / "seen.png").stat().st_size > 10_000
    # The annotation draws the rods' axes where they were placed (magenta): all eight, over 100 px each.
    seen = cv2.imread(str(tmp_path / "seen.png"))
    assert np.count_nonzero(np.all(seen == (255, 0, 255), axis=2)) > 8 * 100


@pytest.mark.timeout(120)
def test_backward_pass_only_adds_frames_with_the_ball(overhead_video, tmp_path):
    """The offline bag holds every frame of the forward pass (what tracker_node publishes, --no-backfill)
    and, from the backward pass, only frames where the ball is on the table, near the truth."""
    markers = markers_of(overhead_video)
    online = ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(tmp_path / "online"),
                      "--no-backfill", "--quiet")
    offline = ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(tmp_path / "offline"),
                       "--quiet")
    assert online.returncode == 0 and offline.returncode == 0, online.stderr + offline.stderr
    truth = truth_of(overhead_video)
    frames = {}
    for name in ("online", "offline"):
        detections = read_ball_detections(tmp_path / name)
        frames[name] = dict(zip(np.round(detections.t * 60).astype(int), detections.position[:, :2]))
    assert set(frames["online"]) <= set(frames["offline"])
    assert np.all(np.diff(read_ball_detections(tmp_path / "offline").t) > 0)  # in frame order
    for k in set(frames["offline"]) - set(frames["online"]):
        assert truth["visible"][k] > 0, k
        assert np.hypot(*(frames["offline"][k] - (truth["x"][k], truth["y"][k]))) < 0.008, k


def one_line_error(result, *words):
    assert result.returncode != 0
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert "Traceback" not in result.stderr
    for word in words:
        assert word in lines[0], lines[0]


@pytest.mark.timeout(120)
def test_bad_input_is_one_line_and_leaves_no_bag(overhead_video, tmp_path):
    markers = markers_of(overhead_video)
    bag = tmp_path / "bag"
    one_line_error(ros2_run("track_video", str(tmp_path / "nope.mp4"), "--markers", markers, "--out", str(bag)),
                   "not found")
    corrupt = tmp_path / "corrupt.mp4"
    corrupt.write_bytes(np.random.default_rng(0).integers(0, 255, 50_000, dtype=np.uint8).tobytes())
    one_line_error(ros2_run("track_video", str(corrupt), "--markers", markers, "--out", str(bag)), "corrupt.mp4")
    wrong = tmp_path / "wrong.yaml"
    wrong.write_text("dictionary: DICT_4X4_50\nsize: 0.06\nmarkers: {10: [0,0,0], 11: [1,0,0], 12: [0,1,0], 13: [1,1,0]}\n")
    one_line_error(ros2_run("track_video", str(overhead_video), "--markers", str(wrong), "--out", str(bag), "--quiet"),
                   "markers file")
    moved = tmp_path / "moved.yaml"
    tree = yaml.safe_load(open(markers))
    tree["markers"][0], tree["markers"][1] = tree["markers"][1], tree["markers"][0]  # two labels swapped
    moved.write_text(yaml.safe_dump(tree))
    one_line_error(ros2_run("track_video", str(overhead_video), "--markers", str(moved), "--out", str(bag), "--quiet"),
                   "markers file")
    assert not bag.exists()
    # One tag knocked off its place: left out of the fit, with a warning that names it.
    tree = yaml.safe_load(open(markers))
    tree["markers"][2][0] -= 0.06
    moved.write_text(yaml.safe_dump(tree))
    result = ros2_run("track_video", str(overhead_video), "--markers", str(moved), "--out", str(bag), "--quiet")
    assert result.returncode == 0, result.stderr
    assert "tag 2 is 60 mm" in result.stderr or "tag 2 is 59 mm" in result.stderr or "tag 2 is 61 mm" in result.stderr, result.stderr
    shutil.rmtree(bag)
    bag.mkdir()
    one_line_error(ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(bag)), "exists")


@pytest.mark.timeout(120)
def test_no_ball_in_sight_and_no_tags_are_errors(tmp_path):
    empty = render(tmp_path / "empty.mp4", "--duration", "0.5", "--fps", "30", "--no-ball")
    result = ros2_run("track_video", str(empty), "--markers", markers_of(empty), "--out", str(tmp_path / "b1"), "--quiet")
    one_line_error(result, "no ball found")
    assert not (tmp_path / "b1").exists()
    # A camera that sees the middle of the field only: no tag in view.
    blind = render(tmp_path / "blind.mp4", "--duration", "0.1", "--fps", "30", "--fovy", "15")
    result = ros2_run("track_video", str(blind), "--markers", markers_of(blind), "--out", str(tmp_path / "b2"), "--quiet")
    one_line_error(result, "tags")


@pytest.mark.timeout(60)
def test_truncated_video_keeps_the_frames_before(overhead_video, tmp_path):
    cut = tmp_path / "cut.mp4"
    data = overhead_video.read_bytes()
    cut.write_bytes(data[: int(len(data) * 0.6)])
    shutil.copy(markers_of(overhead_video), tmp_path / "m.yaml")
    result = ros2_run("track_video", str(cut), "--markers", str(tmp_path / "m.yaml"), "--out", str(tmp_path / "bag"),
                      "--quiet")
    if result.returncode == 2:
        # Some FFmpeg builds refuse an mp4 without its index outright: still one clear line.
        one_line_error(result, "cut.mp4")
        return
    assert result.returncode in (0, 1), result.stderr
    assert len(read_ball_detections(tmp_path / "bag").t) > 0


def test_help_answers_the_users_questions():
    for exe, words in (("track_video", ["--markers", "--ball-color", "--start-time", "--csv-metres", "Exit status",
                                        "--no-backfill", "tracker_node"]),
                       ("render_video", ["--params-file", "--scenario", "truth.csv", "--distortion", "--blur"]),
                       ("calibrate_camera", ["--board", "INNER"])):
        result = ros2_run(exe, "--help")
        assert result.returncode == 0
        for word in words:
            assert word in result.stdout, (exe, word)
