"""`ros2 run foos_sim record_sim`: a "measured" bag from the simulator, with the camera's noise, latency and
dropouts it is told."""
from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np

from foos_bag import messages, read_ball_detections, read_ball_states, read_joint_states

from ..user_env import workspace_env


def run_cli(args: list[str], cwd: Path) -> subprocess.CompletedProcess:
    # offline, but a domain of foos_sim's range (10-19) in case the command touches DDS
    return subprocess.run(args, cwd=cwd, env=workspace_env(domain=19), capture_output=True, text=True, timeout=60)


def test_record_sim_makes_a_measured_bag(tmp_path):
    r = run_cli(["ros2", "run", "foos_sim", "record_sim", "m", "--duration", "2", "--noise", "0.003",
                 "--latency", "0.04", "--dropout", "0.2", "--seed", "7", "--truth-topic", "/sim/ball_truth"], tmp_path)
    assert r.returncode == 0, r.stderr
    det = read_ball_detections(tmp_path / "m")
    truth = read_ball_states(tmp_path / "m", topic="/sim/ball_truth")
    # Dropouts: about 20% of the 240 frames are missing.
    assert 150 < len(det.t) < 225
    # Latency: each detection is received 40 ms after its capture stamp.
    recv = np.array([ns for _, ns, _ in messages(tmp_path / "m", ["/ball/detection"])]) * 1e-9
    np.testing.assert_allclose(np.sort(recv) - det.t, 0.04, atol=1e-6)
    # Noise: detections scatter about the true position (interpolated at the capture time) by ~3 mm.
    true_x = np.interp(det.t, truth.t, truth.position[:, 0])
    true_y = np.interp(det.t, truth.t, truth.position[:, 1])
    err = np.r_[det.position[:, 0] - true_x, det.position[:, 1] - true_y]
    assert 0.002 < np.std(err) < 0.006
    assert len(read_joint_states(tmp_path / "m").names) == 16
    again = run_cli(["ros2", "run", "foos_sim", "record_sim", "m"], tmp_path)
    assert again.returncode == 1 and "exists already" in again.stderr
