"""The camera in the loop over DDS, as on a real table (ROS_DOMAIN_ID 59): `sim_node` films the simulated
table (`camera_rate`), `tracker_node` with its default parameters tracks the images, and a probe compares
its detections with sim_node's true ball (/sim/ball/state) and times the chain (foos_vision.camera_loop,
which `./scripts/bench_camera_loop` runs too)."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import BALL_DETECTION_TOPIC, BALL_STATE_TOPIC
from foos_vision.camera_loop import frame_times, run_loop, summarise

pytestmark = pytest.mark.dds

DOMAIN = 59
CAMERA_RATE = 30.0  # Hz of sim time; sim_node runs as fast as its renderer allows


def logs_of(log_dir) -> str:
    return (log_dir / "sim.log").read_text()[-3000:] + (log_dir / "tracker.log").read_text()[-3000:]


@pytest.mark.timeout(240)
def test_sim_camera_to_tracker_node_finds_the_true_ball(tmp_path):
    record = run_loop(DOMAIN, CAMERA_RATE, 640, 480, frames=150, log_dir=tmp_path, timeout=170, tracked_frames=100)
    assert len(record.detections), logs_of(tmp_path)
    logs = logs_of(tmp_path)
    assert len(record.images) >= 150, logs
    # sim_node publishes no ball of its own on the contract's topics while its camera is on: the tracker does.
    assert record.publishers[BALL_DETECTION_TOPIC] == 1 and record.publishers[BALL_STATE_TOPIC] == 1
    stamps = np.array(sorted(record.images))
    # Each image is stamped with the simulated time of the state it shows: the camera's period apart.
    assert np.median(np.diff(stamps)) == pytest.approx(1 / CAMERA_RATE, abs=0.0021)
    info = record.infos[-1]
    assert (info.width, info.height, info.distortion_model) == (640, 480, "plumb_bob") and info.k[0] > 0
    # Every detection carries the stamp of a frame: a camera period's multiple, to the physics step (2 ms).
    grid = frame_times(CAMERA_RATE, 0.0, record.detections[:, 0].max() + 1)
    assert np.all(np.min(np.abs(record.detections[:, [0]] - grid[None, :]), axis=1) <= 0.0011)
    summary = summarise(record)
    print(f"\ncamera loop: {summary.line()}")
    # Once started (the tags found, the colour voted), the tracker keeps the ball; a busy tracker drops a frame.
    # The tracker learns the ball's colour from a ball that moves. With this serve the ball rolls until 2.1 s,
    # rests against a figure until about 7.5 s, then rolls again: a tracker that heard too few frames of the
    # first roll (sim time runs as fast as the renderer, frames are dropped while the tracker starts) starts at
    # 7.9 s instead of 0.4-2.2 s (measured: 3 of 6 quiet runs). Replayed offline with every frame, it starts at
    # 0.77 s. The tracked stretch is counted in frames after the start (tracked_frames), so both starts give
    # the same checks below.
    assert summary.first_detection < 9.0, logs
    assert summary.detections >= 0.8 * summary.frames_on_field, logs
    assert summary.median_error_mm < 3.0 and summary.p95_error_mm < 10.0
    assert summary.latency_median_ms < 500
