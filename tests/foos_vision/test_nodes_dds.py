"""video_source -> tracker_node over DDS, started with `ros2 run` as a user does (ROS_DOMAIN_ID 41-42)."""
from __future__ import annotations

import signal
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor

from foos_sim.camera.render import read_truth

from .helpers import spawn, stop_node

pytestmark = pytest.mark.dds


@pytest.mark.timeout(120)
def test_video_source_to_tracker_node_stamps_are_capture_times(overhead_video, tmp_path):
    domain = 41
    truth = read_truth(overhead_video.with_suffix("").as_posix() + ".truth.csv")
    markers = overhead_video.with_suffix("").as_posix() + ".markers.yaml"
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("vision_test_listener", context=context)
    received: list[tuple[float, float, float, float]] = []
    states: list[Odometry] = []
    node.create_subscription(PointStamped, "/ball/detection", lambda m: received.append(
        (m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.point.x, m.point.y, time.monotonic())), 100)
    node.create_subscription(Odometry, "/ball/state", states.append, 100)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    logs = [open(tmp_path / f"{name}.log", "wb") for name in ("tracker", "source")]
    tracker = spawn(domain, "tracker_node", f"markers:={markers}", "ball_color:=yellow", log=logs[0])
    source = None
    try:
        # The tracker must be up before the first frame; its subscription shows in the graph.
        end = time.monotonic() + 30
        while time.monotonic() < end and node.count_publishers("/ball/detection") == 0:
            executor.spin_once(timeout_sec=0.1)
        assert node.count_publishers("/ball/detection") == 1, (tmp_path / "tracker.log").read_text()
        source = spawn(domain, "video_source", f"source:={overhead_video}", "start_time:=50.0",
                       "wait_for_subscribers:=1", log=logs[1])
        end = time.monotonic() + 40
        while time.monotonic() < end and source.poll() is None:
            executor.spin_once(timeout_sec=0.05)
        assert source.returncode == 0, (tmp_path / "source.log").read_text()
        end = time.monotonic() + 3
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        if source is not None:
            stop_node(source)
        assert stop_node(tracker) == 0, (tmp_path / "tracker.log").read_text()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        for log in logs:
            log.close()
    assert len(received) >= 25, (tmp_path / "tracker.log").read_text()
    stamps = np.array([r[0] for r in received])
    frames = np.round((stamps - 50.0) * 60).astype(int)
    # Every stamp is a frame's capture time (start_time + index / fps), never the time of processing.
    assert np.allclose(stamps, 50.0 + frames / 60, atol=1e-6)
    assert np.all(np.diff(stamps) > 0)
    assert not np.any(np.isnan(truth["x"][frames]))
    error = np.hypot(np.array([r[1] for r in received]) - truth["x"][frames],
                     np.array([r[2] for r in received]) - truth["y"][frames])
    assert np.median(error) < 0.004
    # Delivered at the video's rate: the detections span about as much wall time as video time.
    arrival = np.array([r[3] for r in received])
    video_span = stamps[-1] - stamps[0]
    assert 0.6 * video_span < arrival[-1] - arrival[0] < video_span + 1.5
    assert len(states) == len(received)
    cov = np.array(states[-1].twist.covariance).reshape(6, 6)
    assert cov[0, 0] > 0 and cov[1, 1] > 0
    assert states[-1].header.frame_id == "table" and states[-1].child_frame_id == "ball"


@pytest.mark.timeout(60)
def test_tracker_node_refuses_a_bad_markers_file(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("markers: {0: [0, 0, 0]}\n")
    with open(tmp_path / "log", "wb") as log:
        proc = spawn(42, "tracker_node", f"markers:={bad}", log=log)
        code = proc.wait(30)
    text = (tmp_path / "log").read_text()
    assert code == 2
    assert "tracker_node: error:" in text and "at least 4" in text and "Traceback" not in text


@pytest.mark.timeout(60)
@pytest.mark.parametrize("sig", [signal.SIGTERM, signal.SIGINT])
def test_nodes_exit_cleanly_on_sigterm_and_ctrl_c(overhead_video, tmp_path, sig):
    for executable, params in (("video_source", [f"source:={overhead_video}", "loop:=true"]), ("tracker_node", [])):
        log_path = tmp_path / f"{executable}.log"
        with open(log_path, "wb") as log:
            proc = spawn(43, executable, *params, log=log)
            time.sleep(4.0)
            assert proc.poll() is None, log_path.read_text()
            proc.send_signal(sig)
            code = proc.wait(15)
        text = log_path.read_text()
        assert code == 0, text
        assert "Traceback" not in text, text
