"""calibrate's command line: help, and one-line errors with a non-zero exit for bad input."""
from __future__ import annotations

import numpy as np

from foos_bag import BagWriter, write_ball_detections, write_joint_states
from foos_core.table_geometry import TableGeometry

BALL_Z = TableGeometry.nominal().ball_centre_height  # m, the plane a camera reports the ball centre in


def one_line_error(result, text):
    """Exit 2 and one error line (last on stderr, after any progress lines), no traceback."""
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    errors = [line for line in lines if line.startswith("calibrate:")]
    assert len(errors) == 1 and errors[0] == lines[-1] and "Traceback" not in result.stderr, result.stderr
    assert text in errors[0], result.stderr


def test_help_says_what_it_needs_and_writes(ros2_run):
    result = ros2_run("calibrate", "--help")
    assert result.returncode == 0
    for text in ("/ball/detection", "report.json", "calibrated_table.yaml", "--out", "--base", "table_tilt"):
        assert text in result.stdout


def test_the_former_foos_sim_command_says_where_it_moved_and_runs_there(ros2_run):
    result = ros2_run("calibrate", "--help", package="foos_sim")
    assert result.returncode == 0, result.stderr
    assert "note: `ros2 run foos_sim calibrate` has moved to `ros2 run foos_calibration calibrate`" in result.stderr
    assert "calibrated_table.yaml" in result.stdout and "--base" in result.stdout


def test_missing_bag(ros2_run, tmp_path):
    one_line_error(ros2_run("calibrate", str(tmp_path / "nope"), "--out", str(tmp_path / "o")), "not found")


def test_not_a_bag(ros2_run, tmp_path):
    (tmp_path / "junk").mkdir()
    (tmp_path / "junk" / "file.txt").write_text("hello")
    one_line_error(ros2_run("calibrate", str(tmp_path / "junk"), "--out", str(tmp_path / "o")), "not a bag")


def test_bag_without_detections(ros2_run, tmp_path):
    with BagWriter(tmp_path / "joints") as w:
        write_joint_states(w, np.arange(5) * 0.01, ["a"], np.zeros((5, 1)), np.zeros((5, 1)))
    one_line_error(ros2_run("calibrate", str(tmp_path / "joints"), "--out", str(tmp_path / "o")), "/ball/detection")


def test_too_little_data(ros2_run, tmp_path):
    with BagWriter(tmp_path / "short") as w:
        t = np.arange(50) / 120
        write_ball_detections(w, t, np.stack([t * 0.5, t * 0, t * 0 + BALL_Z], axis=1))
    one_line_error(ros2_run("calibrate", str(tmp_path / "short"), "--out", str(tmp_path / "o")), "too little")


def test_no_rolling_data(ros2_run, tmp_path):
    # A ball lying still for 10 s: plenty of detections, nothing to calibrate on.
    with BagWriter(tmp_path / "still") as w:
        t = np.arange(1200) / 120
        write_ball_detections(w, t, np.tile([0.1, 0.2, BALL_Z], (1200, 1)) + np.random.default_rng(0).normal(0, 0.0015, (1200, 3)))
    one_line_error(ros2_run("calibrate", str(tmp_path / "still"), "--out", str(tmp_path / "o")), "too little rolling data")
