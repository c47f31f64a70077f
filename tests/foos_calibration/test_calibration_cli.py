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


def _rolls(n: int = 1200) -> np.ndarray:
    """A ball rolling at 0.5 m/s along x, with camera noise: detections that would be fine on a good clock."""
    k = np.arange(n)
    x = -0.3 + (k % 120) / 120 * 0.5
    return np.stack([x, 0 * x + 0.1, 0 * x + BALL_Z], axis=1) + np.random.default_rng(1).normal(0, 0.0015, (n, 3)) * [1, 1, 0]


def test_a_broken_time_base_is_said_not_fitted(ros2_run, tmp_path):
    """Stamps in milliseconds read as seconds, and stamps of whole arrival batches: said, not fitted."""
    with BagWriter(tmp_path / "ms") as w:
        write_ball_detections(w, np.arange(1200) / 120 * 1000, _rolls())
    one_line_error(ros2_run("calibrate", str(tmp_path / "ms"), "--out", str(tmp_path / "o1")), "broken time base")
    with BagWriter(tmp_path / "batches") as w:
        write_ball_detections(w, np.floor(np.arange(1200) / 120 * 10) / 10, _rolls())  # 12 frames share each stamp
    one_line_error(ros2_run("calibrate", str(tmp_path / "batches"), "--out", str(tmp_path / "o2")), "broken time base")
    assert not (tmp_path / "o1").exists() and not (tmp_path / "o2").exists()
