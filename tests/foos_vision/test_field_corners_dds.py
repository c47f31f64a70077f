"""tracker_node with field_corners instead of markers, started with `ros2 run` as a user does and fed frames over DDS
(ROS_DOMAIN_ID 55-56)."""
from __future__ import annotations

import time

import cv2
import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import Image

from foos_core.stamps import seconds_to_stamp, stamp_to_seconds
from foos_core.table_geometry import TableGeometry
from foos_sim.camera.render import read_truth

from .helpers import spawn, stop_node, tracker_exit
from .test_field_corners import clicked, field_corner_pixels, rendered_camera

pytestmark = pytest.mark.dds


def film(node, executor, video, pace: float) -> None:
    """Publish the video's frames as a camera driver does (bgr8, stamped at frame index / 60 s), pace frames a
    second, spinning the listener between them."""
    images = node.create_publisher(Image, "/camera/image_raw", 10)
    capture = cv2.VideoCapture(str(video))
    index = 0
    while True:
        ok, frame = capture.read()
        if not ok:
            break
        msg = Image(encoding="bgr8", height=frame.shape[0], width=frame.shape[1], step=frame.shape[1] * 3,
                    data=frame.tobytes())
        msg.header.stamp = seconds_to_stamp(index / 60, type(msg.header.stamp))
        images.publish(msg)
        index += 1
        due = time.monotonic() + 1.0 / pace
        while time.monotonic() < due:
            executor.spin_once(timeout_sec=0.01)
    capture.release()


@pytest.mark.timeout(120)
def test_tracker_node_tracks_from_field_corners(overhead_video, tmp_path):
    """field_corners as a ROS list (all decimals: ROS refuses a list mixing integers and decimals)."""
    domain = 55
    truth = read_truth(overhead_video.with_suffix("").as_posix() + ".truth.csv")
    corners = clicked(field_corner_pixels(rendered_camera(overhead_video), TableGeometry.nominal()), 4)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("corners_test_camera", context=context)
    received: list[tuple[float, float, float]] = []
    node.create_subscription(PointStamped, "/ball/detection", lambda m: received.append(
        (stamp_to_seconds(m.header.stamp), m.point.x, m.point.y)), 100)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    log_path = tmp_path / "tracker.log"
    with open(log_path, "wb") as log:
        tracker = spawn(domain, "tracker_node", f"field_corners:=[{corners}]", "ball_color:=yellow", log=log)
        try:
            end = time.monotonic() + 30
            while time.monotonic() < end and node.count_subscribers("/camera/image_raw") == 0:
                executor.spin_once(timeout_sec=0.1)
            assert node.count_subscribers("/camera/image_raw") == 1, log_path.read_text()
            # 20 frames a second: the first frame, which fits the corners to the table's edges and places the
            # rods, takes up to a second on a loaded machine; the queue holds the frames meanwhile.
            film(node, executor, overhead_video, pace=20)
            end = time.monotonic() + 3
            while time.monotonic() < end:
                executor.spin_once(timeout_sec=0.05)
        finally:
            assert stop_node(tracker) == 0, log_path.read_text()
            executor.shutdown()
            node.destroy_node()
            rclpy.shutdown(context=context)
    assert len(received) >= 25, log_path.read_text()
    frames = np.round(np.array([r[0] for r in received]) * 60).astype(int)
    assert not np.any(np.isnan(truth["x"][frames]))
    error = np.hypot(np.array([r[1] for r in received]) - truth["x"][frames],
                     np.array([r[2] for r in received]) - truth["y"][frames])
    assert np.median(error) <= 0.003


@pytest.mark.timeout(90)
def test_tracker_node_refuses_corners_outside_its_images(overhead_video, tmp_path):
    """The image size is known only once a frame arrives: the first frame ends the node with one line."""
    code, text = tracker_exit(56, "136,136,136,343,702,343,702,136", overhead_video, tmp_path, 45)
    assert code == 2, text
    errors = [line for line in text.splitlines() if "error" in line]
    assert errors == ["tracker_node: error: field_corners: corner 3 (702, 343) lies outside the 640x480 image"], text
    assert "Traceback" not in text


@pytest.mark.timeout(60)
def test_tracker_node_refuses_markers_with_field_corners(tmp_path):
    with open(tmp_path / "log", "wb") as log:
        proc = spawn(56, "tracker_node", "markers:=some.yaml", "field_corners:=136,136,136,343,502,343,502,136", log=log)
        code = proc.wait(30)
    text = (tmp_path / "log").read_text()
    assert code == 2, text
    assert "tracker_node: error: give exactly one of markers" in text and "Traceback" not in text
