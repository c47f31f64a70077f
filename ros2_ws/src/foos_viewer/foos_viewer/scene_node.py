"""scene_node: the table live in Foxglove. Reads the contract's topics, serves a Foxglove WebSocket.

Subscribes to /joint_states, /ball/state and /ball/detection (best effort, so it matches reliable and
best-effort publishers alike: sim_node, or a real table's encoders and tracker) and publishes a 3D scene in
frame `table` on the WebSocket topics /scene/table, /scene/rods, /scene/ball and /scene/detections.

    ros2 run foos_viewer scene_node                       # then in Foxglove: Open connection ->
                                                          # Foxglove WebSocket -> ws://localhost:8765
    ros2 run foos_viewer scene_node --ros-args -p port:=8766 -p params_file:=out/calibration/calibrated.yaml
"""
from __future__ import annotations

import sys

from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.clock import Clock, ClockType
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.node import Node
from rclpy.qos import qos_profile_sensor_data
from sensor_msgs.msg import JointState

from foos_core.names import BALL_DETECTION_TOPIC, BALL_STATE_TOPIC, JOINT_STATES_TOPIC
from foos_core.nodes import run_node
from foos_core.table_params import ParamsError

from .live import LiveScene
from .scene import TableScene

PARAMETERS = (
    ("port", 8765, "TCP port of the Foxglove WebSocket server; 0 = any free port (the log says which)"),
    ("host", "127.0.0.1", "address to serve on; 0.0.0.0 lets other machines connect"),
    ("params_file", "", "table parameter file (YAML) the scene is drawn from; empty = the nominal regulation table"),
    ("max_rate", 30.0, "Hz: the most updates per second on each scene topic"),
    ("trail_seconds", 0.5, "s of /ball/detection history drawn as the detections' trail"),
)


def _number(values: dict, name: str, kind: type):
    """A numeric parameter as `kind`: `-p port:=abc` or `-p port:=8765.5` is one clear line, not a traceback."""
    value = values[name]
    try:
        number = kind(value)
    except (TypeError, ValueError):
        number = None
    if number is None or isinstance(value, bool) or (kind is int and float(value) != number):
        raise ValueError(f"{name} must be a {'whole ' if kind is int else ''}number, got {value!r}")
    return number


def _stamp(msg) -> tuple[int, int]:
    return (msg.header.stamp.sec, msg.header.stamp.nanosec)


class SceneNode(Node):
    def __init__(self):
        super().__init__("scene_node")
        # Dynamic typing lets a user write `-p max_rate:=20` for a float parameter.
        declared = self.declare_parameters("", [(name, default, ParameterDescriptor(description=text, dynamic_typing=True))
                                                for name, default, text in PARAMETERS])
        value = {parameter.name: parameter.value for parameter in declared}
        params_file = str(value["params_file"]) or None
        scene = TableScene(params_file)  # the model first: a bad file stops us before a port is taken
        self.live = LiveScene(scene, host=str(value["host"]), port=_number(value, "port", int),
                              max_rate=_number(value, "max_rate", float), trail_seconds=_number(value, "trail_seconds", float))
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.on_joints, qos_profile_sensor_data)
        self.create_subscription(Odometry, BALL_STATE_TOPIC, self.on_ball, qos_profile_sensor_data)
        self.create_subscription(PointStamped, BALL_DETECTION_TOPIC, self.on_detection, qos_profile_sensor_data)
        # Held updates go out on the wall clock: with use_sim_time a stopped or racing /clock must not
        # stall or flood the viewer.
        self.create_timer(self.live.min_interval / 2, self.live.flush, clock=Clock(clock_type=ClockType.STEADY_TIME))
        self.get_logger().info(
            f"table from {params_file or 'the nominal parameters'}; Foxglove WebSocket on {self.live.host}:{self.live.port}: "
            f"in Foxglove, Open connection -> Foxglove WebSocket -> {self.live.url}"
        )

    def _take(self, topic: str, update) -> None:
        try:
            update()
        except ValueError as error:
            self.get_logger().warning(f"{topic} ignored: {error}", throttle_duration_sec=1.0)

    def on_joints(self, msg: JointState) -> None:
        self._take(JOINT_STATES_TOPIC, lambda: self.live.set_joints(msg.name, msg.position, _stamp(msg)))

    def on_ball(self, msg: Odometry) -> None:
        p, v = msg.pose.pose.position, msg.twist.twist.linear
        self._take(BALL_STATE_TOPIC, lambda: self.live.set_ball((p.x, p.y, p.z), (v.x, v.y, v.z), _stamp(msg)))

    def on_detection(self, msg: PointStamped) -> None:
        p = msg.point
        self._take(BALL_DETECTION_TOPIC, lambda: self.live.add_detection((p.x, p.y, p.z), _stamp(msg)))

    def close(self) -> None:
        sent = ", ".join(f"{topic} {count}" for topic, count in self.live.sent.items())
        self.get_logger().info(f"scene updates sent: {sent}")
        self.live.close()


def main(args=None) -> int:
    return run_node(
        "scene_node", SceneNode, args=args, on_exit=SceneNode.close,
        errors=(ParamsError, ValueError, TypeError, InvalidParameterTypeException, InvalidParameterValueException),
    )


if __name__ == "__main__":
    sys.exit(main())
