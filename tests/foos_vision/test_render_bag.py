"""render_video from a bag of ball and rod states: the truth follows the bag, rods and all."""
from __future__ import annotations

import numpy as np
import pytest

from foos_bag import BagWriter, write_ball_states, write_joint_states
from foos_core.names import JOINT_NAMES
from foos_vision.render import read_truth

from .helpers import render, ros2_run


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
