"""sim_node: the simulated table on the contract's topics.

Publishes /joint_states, /ball/state, /ball/detection, /sim/goal (std_msgs/String: the team that
scored) and, with publish_clock, /clock. With camera_rate > 0 the simulated camera is on, as on a real table:
/camera/image_raw (bgr8) and /camera/camera_info, each image stamped with the simulated time of the state it
shows, and no /ball/detection or /ball/state (tracker_node makes them from the images); the true ball goes
out on /sim/ball/state instead. Takes /home/rods/command and /away/rods/command
(Float64MultiArray, 8 target velocities). Service /sim/reset (std_srvs/Trigger): rods centred, ball
served again, score kept.

Time: with publish_clock false, stamps are this node's system clock at the start plus simulated time,
and the simulation is paced at real_time_factor. With publish_clock true, simulated time is the ROS
time (it starts at 0 and goes out on /clock); real_time_factor 0 runs as fast as the CPU allows.

Threads: the simulation runs in the main thread; the executor spins in a second one and hands commands
and reset requests over through a queue, applied before the next event. Spinning in the simulation's
loop cost 0.3-1.3 ms a turn (rclpy builds its wait set each time): flat out, at 220 events a simulated
second, sim_node ran at 7x real time.
"""
from __future__ import annotations

import array
import math
import queue
import sys
import threading
import time

import numpy as np
import rclpy
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.exceptions import InvalidParameterTypeException, InvalidParameterValueException
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import CameraInfo, Image, JointState
from std_msgs.msg import Float64MultiArray, String
from std_srvs.srv import Trigger

from foos_core import node_signals
from foos_core.names import (
    BALL_DETECTION_TOPIC,
    BALL_FRAME,
    BALL_STATE_TOPIC,
    CAMERA_FRAME,
    CAMERA_IMAGE_TOPIC,
    CAMERA_INFO_TOPIC,
    CLOCK_TOPIC,
    GOAL_TOPIC,
    JOINT_NAMES,
    JOINT_STATES_TOPIC,
    SIM_BALL_STATE_TOPIC,
    TABLE_FRAME,
    TEAMS,
    command_topic,
)
from foos_core.nodes import run_node
from foos_core.table_params import ParamsError

from .camera.errors import RenderError
from .camera.live import LiveCamera, LiveCameraConfig, ros_distortion_model
from .sim_runner import CameraFrame, Detection, Goal, RunnerConfig, SimRunner, StateSample
from .simulation import CommandError, TableSimulation

BEHIND_RESYNC_S = 0.5  # s: when pacing falls this far behind the wall clock, stop trying to catch up
RESET_WAIT_S = 5.0  # s a /sim/reset call waits for the simulation's thread to take it
PARAMETERS = (
    ("params_file", "", "table parameter file (YAML); empty = the nominal regulation table"),
    ("publish_rate", 100.0, "Hz of /joint_states and /ball/state (ground truth)"),
    ("detection_rate", 120.0, "Hz of /ball/detection, the simulated camera's frame rate"),
    ("real_time_factor", 1.0, "simulated seconds per wall second; 0 = as fast as possible (needs publish_clock)"),
    ("publish_clock", False, "run on simulated time starting at 0 and publish it on /clock"),
    ("seed", 0, "random seed of serves, detection noise and dropouts"),
    ("serve", "random", "none: ball_* initial state, kept after a goal; center: ball at rest at the centre "
     "after each goal; random: a hand-launch-like roll (0.3-3 m/s, random place) whenever the ball rests or scores"),
    ("ball_x", 0.0, "initial ball x (m) with serve none"),
    ("ball_y", 0.0, "initial ball y (m) with serve none"),
    ("ball_vx", 0.0, "initial ball vx (m/s) with serve none"),
    ("ball_vy", 0.0, "initial ball vy (m/s) with serve none"),
    ("detection_noise", 0.0, "m, std of Gaussian noise added to detections (x and y)"),
    ("detection_latency", 0.0, "s from a frame's capture to its detection's publication (stamp = capture)"),
    ("detection_dropout", 0.0, "probability that a frame yields no detection"),
    ("command_timeout", 0.5, "s without a command after which a team's rods are stopped (watchdog)"),
    ("camera_rate", 0.0, "Hz of /camera/image_raw from the simulated camera; 0 = no camera. On: no /ball/detection "
     "or /ball/state (tracker_node makes them), the true ball on /sim/ball/state"),
    ("camera_width", 640, "px, the simulated camera's image width"),
    ("camera_height", 480, "px, the simulated camera's image height"),
    ("camera", "overhead", "the simulated camera: a shipped one (overhead, oblique, fisheye) or a camera YAML"),
    ("camera_ball_color", "white", "the ball's colour in the images: white, yellow, orange, red"),
    ("camera_noise", 1.5, "sensor noise of the images, std in 8-bit levels"),
)


class SimNode(Node):
    def __init__(self):
        super().__init__("sim_node")
        for name, default, description in PARAMETERS:
            # Dynamic typing lets users write `-p real_time_factor:=0` for a float parameter.
            self.declare_parameter(name, default, ParameterDescriptor(description=description, dynamic_typing=True))
        param = lambda name: self.get_parameter(name).value  # noqa: E731
        params_file = param("params_file") or None
        config = RunnerConfig(
            publish_rate=float(param("publish_rate")),
            detection_rate=float(param("detection_rate")),
            detection_noise=float(param("detection_noise")),
            detection_latency=float(param("detection_latency")),
            detection_dropout=float(param("detection_dropout")),
            command_timeout=float(param("command_timeout")),
            serve=str(param("serve")),
            initial_ball=(float(param("ball_x")), float(param("ball_y")), float(param("ball_vx")), float(param("ball_vy"))),
            seed=int(param("seed")),
            camera_rate=float(param("camera_rate")),
        )
        self.real_time_factor = float(param("real_time_factor"))
        if not (math.isfinite(self.real_time_factor) and self.real_time_factor >= 0):
            raise ValueError(f"real_time_factor must be >= 0, got {self.real_time_factor}")
        self.publish_clock = bool(param("publish_clock"))
        if self.real_time_factor == 0 and not self.publish_clock:
            raise ValueError("real_time_factor 0 (as fast as possible) needs publish_clock:=true")

        self.runner = SimRunner(TableSimulation(params_file), config)
        self.camera = None
        if config.camera_rate > 0:
            self.camera = LiveCamera(LiveCameraConfig(
                rate=config.camera_rate, width=int(param("camera_width")), height=int(param("camera_height")),
                camera=str(param("camera")), ball_colour=str(param("camera_ball_color")),
                noise=float(param("camera_noise")), seed=config.seed), params_file)
        self._last_warning: dict[str, float] = {}
        self._stamp_base_ns = 0 if self.publish_clock else self.get_clock().now().nanoseconds
        self._inbox: queue.SimpleQueue = queue.SimpleQueue()  # from the executor's thread to the simulation's
        self._wake = threading.Event()  # a paced loop waiting for its next event wakes for the inbox
        self._pace: tuple[float, float] | None = None  # (wall, simulated) times the paced loop keeps in step
        # Messages reused for every sample (only their values change): building them was a third of the cost.
        self._joints = JointState()
        self._joints.name = list(JOINT_NAMES)
        self._odom = Odometry()
        self._odom.header.frame_id = TABLE_FRAME
        self._odom.child_frame_id = BALL_FRAME
        self._odom.pose.pose.orientation.w = 1.0
        self._detection = PointStamped()
        self._detection.header.frame_id = TABLE_FRAME
        self._clock = Clock()

        self.joint_pub = self.create_publisher(JointState, JOINT_STATES_TOPIC, 10)
        if self.camera is None:
            self.state_pub = self.create_publisher(Odometry, BALL_STATE_TOPIC, 10)
            self.detection_pub = self.create_publisher(PointStamped, BALL_DETECTION_TOPIC, 10)
        else:  # the tracker publishes the contract's ball topics from the images; the true ball is sim_node's own
            self.state_pub = self.create_publisher(Odometry, SIM_BALL_STATE_TOPIC, 10)
            self.image_pub = self.create_publisher(Image, CAMERA_IMAGE_TOPIC, 10)
            self.info_pub = self.create_publisher(CameraInfo, CAMERA_INFO_TOPIC, 10)
            self._image, self._info = self._camera_messages()
        self.goal_pub = self.create_publisher(String, GOAL_TOPIC, 10)
        self.clock_pub = self.create_publisher(Clock, CLOCK_TOPIC, 10) if self.publish_clock else None
        for team in TEAMS:
            self.create_subscription(
                Float64MultiArray, command_topic(team), lambda msg, team=team: self.on_command(team, msg), 10
            )
        self.create_service(Trigger, "/sim/reset", self.on_reset)
        self.get_logger().info(
            f"table from {params_file or 'the nominal parameters'}; {self.runner.sim.physics} physics at "
            f"{1 / self.runner.sim.timestep:.0f} Hz, "
            f"states {config.publish_rate:g} Hz, "
            + (f"detections {config.detection_rate:g} Hz" if self.camera is None else
               f"camera {config.camera_rate:g} Hz {self.camera.camera.width}x{self.camera.camera.height} "
               f"({self.camera.camera.name})")
            + f", serve '{config.serve}', "
            + ("sim time on /clock" if self.publish_clock else "real time")
            + (f" x{self.real_time_factor:g}" if self.real_time_factor > 0 else " as fast as possible")
        )

    # --- inputs (the executor's thread hands them over; the simulation's thread applies them) -------
    def on_command(self, team: str, msg: Float64MultiArray) -> None:
        self._inbox.put((self.apply_command, (team, list(msg.data), time.monotonic())))
        self._wake.set()

    def apply_command(self, team: str, values: list, received: float | None = None) -> None:
        try:
            applied = self.runner.command(team, values, at=self.arrival_time(received))
        except CommandError as error:
            self.warn_throttled(f"{command_topic(team)} refused: {error}; rods keep their last command")
            return
        if any(abs(a - v) > 1e-12 for a, v in zip(applied, values)):
            self.get_logger().info(f"{command_topic(team)} clipped to the drive limits", throttle_duration_sec=5.0)

    def arrival_time(self, received: float | None) -> float | None:
        """The simulated time of a command received at wall time `received` (time.monotonic()) while the loop is
        paced: the drives act on it then, within a physics step, not at the last event's time. None: now."""
        if received is None or self._pace is None:
            return None
        wall_start, sim_start = self._pace
        return sim_start + (received - wall_start) * self.real_time_factor

    def drain_inbox(self) -> None:
        while True:
            try:
                handle, arguments = self._inbox.get_nowait()
            except queue.Empty:
                return
            handle(*arguments)

    def warn_throttled(self, message: str, period: float = 1.0) -> None:
        """Warn once per period for each distinct message (rclpy throttles per call site, hiding others)."""
        now = time.monotonic()
        if now - self._last_warning.get(message, -math.inf) >= period:
            self._last_warning[message] = now
            self.get_logger().warning(message)

    def on_reset(self, request: Trigger.Request, response: Trigger.Response) -> Trigger.Response:
        done = threading.Event()
        self._inbox.put((self.apply_reset, (response, done)))
        self._wake.set()
        if not done.wait(RESET_WAIT_S):
            response.success = False
            response.message = "the simulation did not take the reset in time"
        return response

    def apply_reset(self, response: Trigger.Response, done: threading.Event) -> None:
        self.runner.reset()
        response.success = True
        response.message = f"reset at t={self.runner.time:.3f} s; score home {self.runner.score['home']} - away {self.runner.score['away']}"
        self.get_logger().info(response.message)
        done.set()

    # --- outputs -------------------------------------------------------------------------------
    def set_stamp(self, stamp, sim_time: float) -> None:
        """Write the ROS time of a simulated time into a message's stamp (faster than building a Time)."""
        stamp.sec, stamp.nanosec = divmod(self._stamp_base_ns + int(round(sim_time * 1e9)), 1_000_000_000)

    def _camera_messages(self) -> tuple[Image, CameraInfo]:
        """The image and camera-info messages reused for every frame (their stamps and pixels change)."""
        intrinsics = self.camera.intrinsics
        image = Image()
        image.header.frame_id = CAMERA_FRAME
        image.height, image.width, image.encoding = intrinsics.height, intrinsics.width, "bgr8"
        image.step = intrinsics.width * 3
        info = CameraInfo()
        info.header.frame_id = CAMERA_FRAME
        info.height, info.width = intrinsics.height, intrinsics.width
        info.distortion_model = ros_distortion_model(intrinsics)
        info.d = [float(v) for v in np.asarray(intrinsics.dist_coeffs).ravel()]
        info.k = [float(v) for v in intrinsics.camera_matrix.ravel()]
        info.r = [1.0, 0.0, 0.0, 0.0, 1.0, 0.0, 0.0, 0.0, 1.0]
        info.p = [float(v) for v in np.hstack([intrinsics.camera_matrix, np.zeros((3, 1))]).ravel()]
        return image, info

    def publish_frame(self, frame: CameraFrame) -> None:
        """Film the state of the frame's time and publish it, stamped with that time (the capture)."""
        image, info = self._image, self._info
        pixels = self.camera.capture(frame.qpos)
        self.set_stamp(image.header.stamp, frame.capture_time)
        info.header.stamp.sec, info.header.stamp.nanosec = image.header.stamp.sec, image.header.stamp.nanosec
        image.data = pixels.tobytes()
        self.image_pub.publish(image)
        self.info_pub.publish(info)

    def publish(self, event) -> None:
        if isinstance(event, StateSample):
            self.publish_state(event)
        elif isinstance(event, CameraFrame):
            self.publish_frame(event)
        elif isinstance(event, Detection):
            msg = self._detection
            self.set_stamp(msg.header.stamp, event.capture_time)
            msg.point.x, msg.point.y, msg.point.z = event.position.tolist()
            self.detection_pub.publish(msg)
        elif isinstance(event, Goal):
            self.goal_pub.publish(String(data=event.team))
            self.get_logger().info(
                f"goal for {event.team} at t={event.time:.2f} s: home {event.score['home']} - away {event.score['away']}"
            )

    def publish_state(self, sample: StateSample) -> None:
        joints, odom = self._joints, self._odom
        self.set_stamp(joints.header.stamp, sample.time)
        odom.header.stamp.sec, odom.header.stamp.nanosec = joints.header.stamp.sec, joints.header.stamp.nanosec
        if self.clock_pub is not None:
            self._clock.clock.sec, self._clock.clock.nanosec = joints.header.stamp.sec, joints.header.stamp.nanosec
            self.clock_pub.publish(self._clock)
        joints.position = array.array("d", sample.joint_positions)
        joints.velocity = array.array("d", sample.joint_velocities)
        joints.effort = array.array("d", sample.joint_efforts)
        self.joint_pub.publish(joints)
        pose, twist = odom.pose.pose, odom.twist.twist
        pose.position.x, pose.position.y, pose.position.z = sample.ball_position.tolist()
        # The child frame keeps the table's axes, so velocities are in table axes as the contract asks.
        twist.linear.x, twist.linear.y, twist.linear.z = sample.ball_velocity.tolist()
        twist.angular.x, twist.angular.y, twist.angular.z = sample.ball_angular_velocity.tolist()
        self.state_pub.publish(odom)

    # --- the loop ------------------------------------------------------------------------------
    def run(self, executor: SingleThreadedExecutor, stop: node_signals.StopSignal) -> None:
        """Advance event by event; pace against the wall clock unless running as fast as possible. The
        executor spins in its own thread meanwhile, until the loop ends."""
        spinning = threading.Event()
        spinning.set()

        def spin() -> None:
            while spinning.is_set() and rclpy.ok():
                executor.spin_once(timeout_sec=node_signals.POLL_S)

        spinner = threading.Thread(target=spin, name="sim_node executor", daemon=True)
        spinner.start()
        try:
            self._advance_until_stopped(stop)
        finally:
            spinning.clear()
            spinner.join(timeout=2.0)

    def _advance_until_stopped(self, stop: node_signals.StopSignal) -> None:
        wall_start, sim_start = time.monotonic(), self.runner.time
        self._pace = (wall_start, sim_start) if self.real_time_factor > 0 else None
        while rclpy.ok() and not stop.requested:
            self.drain_inbox()
            for event in self.runner.advance():
                self.publish(event)
            if self.real_time_factor == 0:
                continue
            due = wall_start + (self.runner.next_event_time() - sim_start) / self.real_time_factor
            if time.monotonic() - due > BEHIND_RESYNC_S:
                self.get_logger().warning("the simulation cannot keep up with the requested real-time factor",
                                          throttle_duration_sec=5.0)
                wall_start, sim_start = time.monotonic(), self.runner.time
                self._pace = (wall_start, sim_start)
                continue
            while not stop.requested:
                remaining = due - time.monotonic()
                if remaining <= 0:
                    break
                if self._wake.wait(remaining):  # a command or a reset arrived: apply it now
                    self._wake.clear()
                    self.drain_inbox()


def main(args=None) -> int:
    return run_node(
        "sim_node", SimNode, run=SimNode.run, args=args,
        errors=(ParamsError, RenderError, ValueError, TypeError, InvalidParameterTypeException, InvalidParameterValueException),
    )


if __name__ == "__main__":
    sys.exit(main())
