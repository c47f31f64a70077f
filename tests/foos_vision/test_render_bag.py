"""render_video from a bag of ball and rod states: the truth follows the bag, rods and all; the measured ball
(/ball/detection) is drawn where the detection says; a bag without rod encoders or without a ball."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from foos_bag import BagWriter, write_ball_detections, write_ball_states, write_joint_states
from foos_core.camera_model import CameraConfig
from foos_core.names import JOINT_NAMES
from foos_sim.camera.render import read_joints, read_truth

from .helpers import render, ros2_run

BALL_Z = 0.0175


def filmed_camera(video) -> CameraConfig:
    """The camera render_video wrote next to the video (its pose and lens; the intrinsics block is derived)."""
    tree = yaml.safe_load(open(video.with_suffix(".camera.yaml")))
    tree.pop("intrinsics")
    return CameraConfig(**{k: tuple(v) if isinstance(v, list) else v for k, v in tree.items()})


def video_frames(video) -> list[np.ndarray]:
    capture = cv2.VideoCapture(str(video))
    frames = []
    while True:
        ok, frame = capture.read()
        if not ok:
            return frames
        frames.append(frame)


def magenta(image: np.ndarray) -> np.ndarray:
    """Pixels of the measured ball's colour (BGR 255, 0, 255), after mp4v's compression."""
    b, g, r = (image[..., i].astype(int) for i in range(3))
    return (b > 170) & (r > 170) & (g < 110)


def colour_at(image: np.ndarray, pixel: np.ndarray) -> np.ndarray:
    """The mean BGR of the 3x3 pixels around a pixel."""
    u, v = np.round(pixel).astype(int)
    return image[v - 1:v + 2, u - 1:u + 2].reshape(-1, 3).mean(axis=0)


@pytest.mark.timeout(120)
def test_render_from_a_bag_follows_the_recorded_ball(tmp_path):
    t = np.linspace(10.0, 10.5, 51)  # a bag's own clock: rendering starts at its first state
    position = np.c_[-0.2 + 0.8 * (t - 10), 0.1 - 0.4 * (t - 10), np.full_like(t, 0.0175)]
    velocity = np.tile([0.8, -0.4, 0.0], (len(t), 1))
    joints = np.zeros((len(t), len(JOINT_NAMES)))
    joints[:, 1::2] = np.linspace(0, np.pi / 2, len(t))[:, None]  # every rod turns its figures up
    bag = tmp_path / "states"
    with BagWriter(bag) as writer:
        write_ball_states(writer, t, position, velocity)
        write_joint_states(writer, t, list(JOINT_NAMES), joints, np.zeros_like(joints))
    video = render(tmp_path / "replay.mp4", "--bag", str(bag), "--fps", "30")
    truth = read_truth(tmp_path / "replay.truth.csv")
    assert len(truth["t"]) == 16  # 0.5 s at 30 fps
    expected_x = np.interp(truth["t"] + 10.0, t, position[:, 0])
    assert np.allclose(truth["x"], expected_x, atol=1e-6)
    assert np.allclose(truth["vx"], 0.8)
    tracked = ros2_run("track_video", str(video), "--markers", str(tmp_path / "replay.markers.yaml"),
                       "--out", str(tmp_path / "bag2"), "--ball-color", "white", "--quiet")
    assert tracked.returncode == 0, tracked.stderr


def test_render_refuses_a_bag_without_ball_states(tmp_path):
    bag = tmp_path / "joints_only"
    with BagWriter(bag) as writer:
        write_joint_states(writer, [0.0, 0.1], list(JOINT_NAMES), np.zeros((2, 16)), np.zeros((2, 16)))
    result = ros2_run("render_video", str(tmp_path / "x.mp4"), "--bag", str(bag), "--quiet")
    assert result.returncode != 0
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert not (tmp_path / "x.mp4").exists()
    assert result.returncode == 2 and "/ball/state" in result.stderr and "/ball/detection" in result.stderr


@pytest.mark.timeout(120)
def test_render_a_tilted_table_for_calibration(tmp_path):
    """The calibration developer's path: a hidden tilt in a params file, free rolls, truth next to the mp4."""
    params = tmp_path / "tilted.yaml"
    params.write_text("base: regulation_table\neffects:\n  - {name: table_tilt, params: {slope_x: 0.02, slope_y: 0.0}}\n")
    render(tmp_path / "tilt.mp4", "--scenario", "rolls", "--params-file", str(params), "--duration", "0.6",
           "--fps", "30", "--seed", "4")
    render(tmp_path / "level.mp4", "--scenario", "rolls", "--duration", "0.6", "--fps", "30", "--seed", "4")
    tilted, level = read_truth(tmp_path / "tilt.truth.csv"), read_truth(tmp_path / "level.truth.csv")
    assert len(tilted["t"]) == 19 and np.all(np.isfinite(tilted["x"]))
    # The same serve on both tables: a 2 % slope toward +x adds 5/7 g 0.02 = 0.14 m/s^2 along x
    # (rolling ball), whatever the rolling resistance does.
    extra = np.median(np.diff(tilted["vx"] - level["vx"]) / np.diff(tilted["t"]))
    assert 0.07 < extra < 0.25
    bad = tmp_path / "bad.yaml"
    bad.write_text("base: regulation_table\neffects: [{name: table_tilt}]\n")
    result = ros2_run("render_video", str(tmp_path / "bad.mp4"), "--params-file", str(bad), "--quiet")
    assert result.returncode != 0 and len(result.stderr.strip().splitlines()) == 1


@pytest.mark.timeout(120)
def test_the_measured_ball_is_drawn_where_the_detection_says(tmp_path):
    """Ball states, rod states and detections 4 cm off the ball state, with a 0.2 s gap: each frame shows the
    rendered ball at the state and a magenta dot at the detection, through the camera written next to the video;
    in the gap, no dot."""
    t = np.linspace(20.0, 20.6, 73)  # 120 Hz
    # Across the table between the midfield rods (y = +/-0.075), where no rod or figure hides either ball.
    state = np.c_[-0.25 + 0.8 * (t - 20), np.full_like(t, -0.01), np.full_like(t, BALL_Z)]
    velocity = np.tile([0.8, 0.0, 0.0], (len(t), 1))
    detection = state + [0.0, 0.04, 0.0]
    seen = (t < 20.15) | (t > 20.35)  # the camera lost the ball for 0.2 s
    joints = np.zeros((len(t), len(JOINT_NAMES)))
    bag = tmp_path / "game"
    with BagWriter(bag) as writer:
        write_ball_states(writer, t, state, velocity)
        write_ball_detections(writer, t[seen], detection[seen])
        write_joint_states(writer, t, list(JOINT_NAMES), joints, np.zeros_like(joints))
    video = render(tmp_path / "game.mp4", "--bag", str(bag), "--fps", "10", "--noise", "0", "--no-shadows")
    camera = filmed_camera(video)
    frames = video_frames(video)
    times = read_truth(tmp_path / "game.truth.csv")["t"]
    assert len(frames) == len(times) == 7
    for frame, time in zip(frames, times):
        bag_time = 20.0 + time
        ball = camera.project(np.array([[np.interp(bag_time, t, state[:, i]) for i in range(3)]]))[0]
        assert colour_at(frame, ball).min() > 180, f"t={time}: no white ball at the /ball/state position"
        dot = magenta(frame)
        if 20.15 < bag_time < 20.35:
            assert dot[60:].sum() == 0, f"t={time}: a measured ball drawn in the detection gap"  # below the legend
            continue
        pixel = camera.project(np.array([[np.interp(bag_time, t[seen], detection[seen, i]) for i in range(3)]]))[0]
        assert magenta(colour_at(frame, pixel)[None, None].astype(np.uint8))[0, 0], f"t={time}: no dot at {pixel}"
        v, u = np.nonzero(dot[60:])
        assert np.hypot(u.mean() - pixel[0], v.mean() + 60 - pixel[1]) < 1.5, f"t={time}: the dot is off {pixel}"


@pytest.mark.timeout(120)
def test_a_bag_without_joint_states_renders_the_rods_hanging_and_says_so(tmp_path):
    """A tracked table without rod encoders: only /ball/detection. The video has the rods centred and hanging, one
    line on stderr says so, exit 0; the ball is the measured one, drawn (the truth has no simulated ball)."""
    t = np.linspace(3.0, 3.35, 43)
    detection = np.c_[0.1 - 0.3 * (t - 3), -0.2 + 0.5 * (t - 3), np.full_like(t, BALL_Z)]
    bag = tmp_path / "tracked"
    with BagWriter(bag) as writer:
        write_ball_detections(writer, t, detection)
    result = ros2_run("render_video", str(tmp_path / "tracked.mp4"), "--bag", str(bag), "--fps", "10", "--quiet",
                      "--no-shadows")
    assert result.returncode == 0, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and "/joint_states" in lines[0] and "hanging" in lines[0], result.stderr
    _, names, rods = read_joints(tmp_path / "tracked.joints.csv")
    assert len(rods) == 4 and np.all(rods == 0.0)  # every slide centred, every figure hanging
    assert np.all(np.isnan(read_truth(tmp_path / "tracked.truth.csv")["x"]))
    camera = filmed_camera(tmp_path / "tracked.mp4")
    for frame, time in zip(video_frames(tmp_path / "tracked.mp4"), np.arange(4) / 10):
        pixel = camera.project(np.array([[np.interp(3.0 + time, t, detection[:, i]) for i in range(3)]]))[0]
        assert magenta(colour_at(frame, pixel)[None, None].astype(np.uint8))[0, 0], f"t={time}: no dot at {pixel}"
