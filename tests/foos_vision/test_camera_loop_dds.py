"""The camera in the loop over DDS, as on a real table (ROS_DOMAIN_ID 57): `sim_node` films the simulated
table (`camera_rate`), `tracker_node` with its default parameters tracks the images, and a probe compares
its detections with sim_node's true ball (/sim/ball/state) and times the chain (foos_vision.camera_loop,
which `./scripts/bench_camera_loop` runs too)."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import BALL_DETECTION_TOPIC, BALL_STATE_TOPIC
from foos_vision.camera_loop import frame_times, run_loop, summarise

pytestmark = pytest.mark.dds

DOMAIN = 57
CAMERA_RATE = 30.0  # Hz of sim time; sim_node runs as fast as its renderer allows


@pytest.mark.timeout(180)
def test_sim_camera_to_tracker_node_finds_the_true_ball(tmp_path):
    record = run_loop(DOMAIN, CAMERA_RATE, 640, 480, frames=150, log_dir=tmp_path, timeout=100)
    logs = (tmp_path / "sim.log").read_text() + (tmp_path / "tracker.log").read_text()
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
    # The start is measured in sim time, which runs as fast as the renderer: the faster it films, the more frames
    # (and sim seconds) pass while the tracker fits the tags and votes the colour (0.4-0.8 s loaded, 1.93 s quiet).
    assert summary.first_detection < 3.0, logs
    assert summary.detections >= 0.8 * summary.frames_on_field, logs
    assert summary.median_error_mm < 3.0 and summary.p95_error_mm < 10.0
    assert summary.latency_median_ms < 500
