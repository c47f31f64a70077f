"""tracker_node: /camera/image_raw -> /ball/detection (PointStamped) and /ball/state (Odometry).

Stamps are the images' stamps (capture time). A frame without a ball publishes nothing.
When /joint_states arrives (rod encoders, or sim_node), the figures are masked out of each frame: the
joint states around the image's stamp (interpolated, or the latest one before it, at most 0.1 s older)
pose the figures, and their pixels are not ball evidence. A frame newer than every reading waits for
the reading of its time (at most 0.1 s of stamps or 0.25 s of wall time; see joint_sync), and the
readings are taken best effort: for the mask the newest reading matters, and a reliable stream holds
every later reading back while a lost one is sent again (seconds, on a loaded machine). Without joint
states (or -p figure_mask:=false) it tracks as before, without waiting.

The table is found in the image by the markers file's tags (`markers`, default the shipped layout) or, for a
table without tags and a camera that does not move, by the pixels of the playing field's corners at (-x,-y),
(+x,-y), (+x,+y), (-x,+y) of the table frame (`field_corners`: a list of 8 numbers, all integers or all
decimals, or the string "U1,V1,...,U4,V4"); the field's size is the params_file's. Not both. `field_corners:=auto`
finds them (field_auto) in field_auto.FRAMES frames spread over the first field_auto.SPAN_S seconds of stamps, which
are not tracked; what was found is logged, and no field found ends the node with one line (exit 2).

    ros2 run foos_vision tracker_node --ros-args -p markers:=table_markers.yaml -p ball_color:=yellow
    ros2 run foos_vision tracker_node --ros-args -p field_corners:=[136,136,136,343,502,343,502,136] \
        -p params_file:=my_table.yaml
"""
from __future__ import annotations

import sys
import time

import numpy as np
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.node import Node
from rclpy.qos import QoSProfile, ReliabilityPolicy
from sensor_msgs.msg import Image, JointState

from foos_core.camera_model import load_intrinsics
from foos_core.command_line import quiet_threads
from foos_core.joints import joint_order, take_joints
from foos_core.markers import DEFAULT_MARKERS_FILE
from foos_core.names import (
    BALL_DETECTION_TOPIC,
    BALL_FRAME,
    BALL_STATE_TOPIC,
    CAMERA_IMAGE_TOPIC,
    JOINT_STATES_TOPIC,
    TABLE_FRAME,
)
from foos_core.nodes import run_node
from foos_core.stamps import stamp_to_seconds
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params

from .camera.field_auto import FRAMES, SPAN_S, FieldNotFound, find_field_corners, is_auto
from .camera.field_corners import field_reference, option_given, parse_field_corners
from .camera.figure_mask import FigureGeometry
from .errors import CameraConfigError, MarkersError, VisionError
from .image_msg import image_to_bgr
from .joint_sync import JointSync, ReadyFrame
from .tracking.tracker import BallTracker, TrackerConfig

# Best effort, deep enough for 0.25 s of 400 Hz encoders while a frame is being tracked.
JOINT_QOS = QoSProfile(depth=100, reliability=ReliabilityPolicy.BEST_EFFORT)


class TrackerNode(Node):
    def __init__(self):
        super().__init__("tracker_node")
        self.declare_parameter("markers", "")  # '' = the shipped layout, unless field_corners is given
        # A list of 8 pixel coordinates or the same as one string: a type of its own, hence dynamic.
        self.declare_parameter("field_corners", "", ParameterDescriptor(dynamic_typing=True))
        self.declare_parameter("ball_color", "auto")
        self.declare_parameter("intrinsics", "")  # calibrate_camera YAML; '' = no undistortion
        self.declare_parameter("tag_interval", 30)
        self.declare_parameter("figure_mask", True)  # mask the figures posed from /joint_states
        self.declare_parameter("params_file", "")  # foos_sim table parameters (figures, rods); '' = nominal
        markers_file, corners = self.get_parameter("markers").value, self.get_parameter("field_corners").value
        if not option_given(corners) and not markers_file:
            markers_file = str(DEFAULT_MARKERS_FILE)
        # auto: the corners are found in the first frames, and the tracker made then.
        self.still: list[np.ndarray] = []
        self.still_last: float | None = None
        layout = None if is_auto(corners) and not markers_file else field_reference(markers_file, corners,
                                                                                      ("markers", "field_corners"))
        intrinsics_file = self.get_parameter("intrinsics").value
        config = TrackerConfig(
            ball_color=self.get_parameter("ball_color").value,
            intrinsics=load_intrinsics(intrinsics_file) if intrinsics_file else None,
            tag_interval=int(self.get_parameter("tag_interval").value),
            params_file=self.get_parameter("params_file").value or None,
        )
        figures = None
        self.sync = JointSync()
        if self.get_parameter("figure_mask").value:
            figures = FigureGeometry(self.get_parameter("params_file").value or None)
            self.create_subscription(JointState, JOINT_STATES_TOPIC, self.on_joint_states, JOINT_QOS)
            self.create_timer(0.05, self.on_timer)
        self.config, self.figures = config, figures
        self.tracker = BallTracker(layout, config, figures) if layout is not None else None
        self.warned_joints = False
        self.detection_pub = self.create_publisher(PointStamped, BALL_DETECTION_TOPIC, 50)
        self.state_pub = self.create_publisher(Odometry, BALL_STATE_TOPIC, 50)
        self.create_subscription(Image, CAMERA_IMAGE_TOPIC, self.on_image, 10)
        self.warned_tags = False
        self.logged_start = False

    def on_joint_states(self, msg: JointState) -> None:
        order = joint_order(msg.name, allow_missing=True)
        if np.any(order < 0) or len(msg.position) < len(msg.name):
            if not self.warned_joints:
                self.get_logger().warning(f"{JOINT_STATES_TOPIC} without all 16 rod joint positions: no figure mask")
                self.warned_joints = True
            return
        position = take_joints(msg.position, order)
        if not np.all(np.isfinite(position)):
            return
        self.track(self.sync.add_joints(stamp_to_seconds(msg.header.stamp), position))

    def on_timer(self) -> None:
        self.track(self.sync.due(time.monotonic()))

    def on_image(self, msg: Image) -> None:
        self.track(self.sync.add_frame(stamp_to_seconds(msg.header.stamp), msg, time.monotonic()))

    def track(self, frames: list[ReadyFrame]) -> None:
        for ready in frames:
            self.track_one(ready.payload, ready.stamp, ready.joints)

    def find_field(self, frame: np.ndarray, t: float) -> None:
        """field_corners auto: keep this frame for the still table if it is far enough in time from the last kept,
        and once there are enough, find the corners and make the tracker (FieldNotFound ends the node)."""
        if self.still_last is not None and abs(t - self.still_last) < SPAN_S / FRAMES:
            return
        self.still.append(frame)
        self.still_last = t
        if len(self.still) < FRAMES:
            return
        table = TableGeometry.of(self.config.params_file)
        wall_height = float(load_params(self.config.params_file)["field"]["wall_height"])
        try:
            found = find_field_corners(self.still, table.half_width, table.half_length, table.goal_half_width,
                                       wall_height, self.config.intrinsics)
        except FieldNotFound as error:  # named as this node's parameter, not track_video's option
            raise FieldNotFound(str(error).replace("--field-corners", "field_corners")) from None
        self.still = []
        self.get_logger().info(found.summary())
        corners = parse_field_corners(list(found.pixels.ravel()), "field_corners auto")
        self.tracker = BallTracker(corners, self.config, self.figures)

    def track_one(self, msg: Image, t: float, joints) -> None:
        try:
            frame = image_to_bgr(msg)
            if self.tracker is None:
                self.find_field(frame, t)
                return
            detection = self.tracker.process(frame, t, joints)
        except (VisionError, MarkersError, CameraConfigError):
            raise  # the table's description does not fit the images: the node ends with one line
        except ValueError as error:  # this frame only (an encoding the node cannot read)
            self.get_logger().warning(f"frame at {t:.3f} s skipped: {error}")
            return
        if self.tracker.mapping is None and not self.warned_tags and self.tracker.stats.frames >= 30:
            self.get_logger().warning(f"no tag fit yet: {self.tracker.last_fit_error or 'no tags seen'}")
            self.warned_tags = True
        if detection is None:
            return
        if not self.logged_start:  # how long the start took: the tag fit, then the ball's colour found
            stats = self.tracker.stats
            self.get_logger().info(f"tracking: first ball at {t:.3f} s, frame {stats.frames} "
                                   f"({stats.frames - stats.frames_with_mapping} before the tag fit)")
            self.logged_start = True
        point = PointStamped()
        point.header.stamp = msg.header.stamp
        point.header.frame_id = TABLE_FRAME
        point.point.x, point.point.y, point.point.z = detection.x, detection.y, detection.z
        self.detection_pub.publish(point)
        state = self.tracker.kalman.state
        odom = Odometry()
        odom.header = point.header
        odom.child_frame_id = BALL_FRAME
        odom.pose.pose.position.x, odom.pose.pose.position.y = float(state.x[0]), float(state.x[1])
        odom.pose.pose.position.z = detection.z
        odom.pose.pose.orientation.w = 1.0
        odom.twist.twist.linear.x, odom.twist.twist.linear.y = float(state.x[2]), float(state.x[3])
        pose_cov = np.zeros((6, 6))
        pose_cov[:2, :2] = state.P[:2, :2]
        twist_cov = np.zeros((6, 6))
        twist_cov[:2, :2] = state.P[2:, 2:]
        odom.pose.covariance = pose_cov.ravel().tolist()
        odom.twist.covariance = twist_cov.ravel().tolist()
        self.state_pub.publish(odom)


def main(args=None) -> int:
    quiet_threads()
    return run_node("tracker_node", TrackerNode, args=args, errors=(VisionError, ValueError, OSError))


if __name__ == "__main__":
    sys.exit(main())
