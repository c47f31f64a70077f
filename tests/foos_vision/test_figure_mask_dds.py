"""tracker_node with /joint_states over DDS (ROS_DOMAIN_ID 43): two nodes side by side, one masking the
figures the joint states pose, one told not to (figure_mask:=false); only the second takes red figures
for the ball."""
from __future__ import annotations

import math
import subprocess
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import Image, JointState

from foos_core.names import JOINT_NAMES
from foos_core.stamps import seconds_to_stamp

from . import drawn_table as dt
from .helpers import stop_node, workspace_env
from .test_figure_mask import RED_BGR, drawn_rod, joints

pytestmark = pytest.mark.dds

DOMAIN = 43
FIGURES_ONLY, WITH_BALL = 90, 60


def start_tracker(markers, log, *extra: str) -> subprocess.Popen:
    args = ["ros2", "run", "foos_vision", "tracker_node", "--ros-args", "-p", f"markers:={markers}",
            "-p", "ball_color:=red", *extra]
    return subprocess.Popen(args, env=workspace_env(DOMAIN), stdout=log, stderr=subprocess.STDOUT)


@pytest.mark.timeout(120)
def test_tracker_node_masks_figures_from_joint_states(tmp_path):
    markers = tmp_path / "markers.yaml"
    dt.write_layout(markers)
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=DOMAIN)
    node = rclpy.create_node("figure_mask_test", context=context)
    seen = {"masked": [], "unmasked": []}
    for key, topic in (("masked", "/ball/detection"), ("unmasked", "/nomask/ball/detection")):
        node.create_subscription(PointStamped, topic, lambda m, key=key: seen[key].append(
            (m.header.stamp.sec + m.header.stamp.nanosec * 1e-9, m.point.x, m.point.y)), 200)
    images = node.create_publisher(Image, "/camera/image_raw", 10)
    joint_pub = node.create_publisher(JointState, "/joint_states", 50)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    logs = [open(tmp_path / f"{name}.log", "wb") for name in ("masked", "unmasked")]
    masked = start_tracker(markers, logs[0])
    unmasked = start_tracker(markers, logs[1], "-p", "figure_mask:=false", "-r", "/ball/detection:=/nomask/ball/detection",
                             "-r", "/ball/state:=/nomask/ball/state", "-r", "__node:=tracker_node_nomask")
    try:
        end = time.monotonic() + 40
        while time.monotonic() < end and (images.get_subscription_count() < 2 or joint_pub.get_subscription_count() < 1):
            executor.spin_once(timeout_sec=0.1)
        assert images.get_subscription_count() == 2, (tmp_path / "masked.log").read_text()
        ball_y = 0.225 - (0.011 + 0.0175 + 0.001)
        def slide_at(k: int) -> float:
            return 0.06 * math.sin(2 * math.pi * 1.5 * (k / dt.FPS))

        def publish_joints(k: int) -> None:
            state = JointState()
            state.header.stamp = seconds_to_stamp(10.0 + k / dt.FPS, type(state.header.stamp))
            state.name = list(JOINT_NAMES)
            state.position = [float(v) for v in joints(slide_at(k))]
            joint_pub.publish(state)

        # Rod encoders run faster than the camera: a frame's joint state is there before the frame (the
        # node does not wait for it; a frame it outruns is masked with the rods' previous pose).
        # Discovery is not symmetric: the publisher may see the subscription before the node sees the
        # publisher, and what is published meanwhile is lost. Frames without joint states are tracked
        # unmasked (a track started on a figure then lives on its foot's rim, below the mask's cut, for the
        # 0.15 s a track may live on parts),
        # so the rods' pose is published for a second before the first frame.
        for _ in range(20):
            publish_joints(0)
            pause = time.monotonic() + 0.05
            while time.monotonic() < pause:
                executor.spin_once(timeout_sec=0.01)
        for k in range(FIGURES_ONLY + WITH_BALL):
            t = 10.0 + k / dt.FPS
            frame = dt.table_frame()
            drawn_rod(frame, slide_at(k))
            if k >= FIGURES_ONLY:
                dt.draw_ball(frame, -0.30 + 0.6 * (k - FIGURES_ONLY) / WITH_BALL, ball_y, bgr=RED_BGR)
            publish_joints(k + 1)
            executor.spin_once(timeout_sec=0.005)
            image = Image()
            image.header.stamp = seconds_to_stamp(t, type(image.header.stamp))
            image.header.frame_id = "camera"
            image.height, image.width = frame.shape[:2]
            image.encoding, image.step = "bgr8", frame.shape[1] * 3
            image.data = frame.tobytes()
            images.publish(image)
            pause = time.monotonic() + 0.02
            while time.monotonic() < pause:
                executor.spin_once(timeout_sec=0.005)
        end = time.monotonic() + 5
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        codes = [stop_node(masked), stop_node(unmasked)]
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
        for log in logs:
            log.close()
    assert codes == [0, 0], (tmp_path / "masked.log").read_text()
    split = 10.0 + (FIGURES_ONLY - 0.5) / dt.FPS
    false_unmasked = [s for s in seen["unmasked"] if s[0] < split]
    false_masked = [s for s in seen["masked"] if s[0] < split]
    assert len(false_unmasked) >= 10, "the drawn figures should pass for a red ball without the mask"
    assert false_masked == [], (tmp_path / "masked.log").read_text()
    balls = [s for s in seen["masked"] if s[0] >= split]
    assert len(balls) >= 0.8 * WITH_BALL, (tmp_path / "masked.log").read_text()
    frames = np.round((np.array([b[0] for b in balls]) - 10.0) * dt.FPS).astype(int) - FIGURES_ONLY
    x_true = -0.30 + 0.6 * frames / WITH_BALL
    assert np.median(np.hypot(np.array([b[1] for b in balls]) - x_true, np.array([b[2] for b in balls]) - ball_y)) < 0.002
