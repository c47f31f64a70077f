"""policy_node: a trained (or baseline) policy playing one team's rods over the contract's topics.

Reads /ball/state (nav_msgs/Odometry) and /joint_states, publishes /<team>/rods/command
(std_msgs/Float64MultiArray, 8 target velocities) at control_rate Hz on the node's clock (sim time
with use_sim_time). Stale or missing inputs hold the rods (zero velocities) with a throttled warning.
The inference latency is logged every latency_period seconds and published on
/<team>/policy/latency (std_msgs/Float64, ms, median of the period).

    ros2 run foos_policy policy_node --ros-args -p policy:=sac_hardened_scripted_s0 -p team:=home
"""
from __future__ import annotations

import sys

import rclpy
from nav_msgs.msg import Odometry
from rcl_interfaces.msg import ParameterDescriptor
from rclpy.duration import Duration
from rclpy.node import Node
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64, Float64MultiArray

from foos_core.names import BALL_STATE_TOPIC, COMMAND_SIZE, JOINT_STATES_TOPIC, TEAMS, command_topic
from foos_core.nodes import run_node
from foos_core.stamps import stamp_to_seconds
from foos_core.table_params import load_params
from foos_sim import command_limits

from .controller import STALE_AFTER_S, PolicyController, StateError, ball_sample, joint_sample
from .policies import PolicyError, make_policy

STOP_ACK_TIMEOUT_S = 2.0  # Fast DDS acknowledged it within 0.01-1.05 s here
PARAMETERS = (
    ("policy", "sac_hardened_scripted_s0", "shipped policy name, PATH.zip, or zero | random | scripted | lift-ahead"),
    ("team", "home", "team to play: home, or away (observations and commands are mirrored)"),
    ("control_rate", 50.0, "Hz of commands (the policies were trained at 50 Hz)"),
    ("stale_timeout", STALE_AFTER_S, "s; older /ball/state or /joint_states (by their stamps) hold the rods"),
    ("latency_period", 5.0, "s between inference-latency reports"),
    ("params_file", "", "table parameter file for the drive limits; empty = nominal table"),
    ("seed", 0, "seed of the random baseline"),
)


class PolicyNode(Node):
    def __init__(self):
        super().__init__("policy_node")
        for name, default, description in PARAMETERS:
            self.declare_parameter(name, default, ParameterDescriptor(description=description, dynamic_typing=True))
        param = lambda name: self.get_parameter(name).value  # noqa: E731
        team = str(param("team"))
        if team not in TEAMS:
            raise ValueError(f"team must be home or away, got `{team}`")
        rate = float(param("control_rate"))
        if not rate > 0:
            raise ValueError(f"control_rate must be positive, got {rate}")
        params = load_params(param("params_file") or None)  # the drive limits and the figure layout
        limits = command_limits(params)
        policy = make_policy(str(param("policy")), params, limits, seed=int(param("seed")))
        self.controller = PolicyController(policy, team, limits, float(param("stale_timeout")))
        self.team = team
        self.command_pub = self.create_publisher(Float64MultiArray, command_topic(team), 10)
        self.latency_pub = self.create_publisher(Float64, f"/{team}/policy/latency", 10)
        self.create_subscription(Odometry, BALL_STATE_TOPIC, self.on_ball, 10)
        self.create_subscription(JointState, JOINT_STATES_TOPIC, self.on_joints, 10)
        self.create_timer(1.0 / rate, self.on_tick)
        self.create_timer(float(param("latency_period")), self.report_latency)
        self.get_logger().info(f"{policy.name} plays {team} at {rate:g} Hz")

    def on_ball(self, msg: Odometry) -> None:
        p, v = msg.pose.pose.position, msg.twist.twist.linear
        try:
            self.controller.ball = ball_sample(stamp_to_seconds(msg.header.stamp), (p.x, p.y, p.z), (v.x, v.y, v.z))
        except StateError as error:
            self.get_logger().warning(f"ignored: {error}", throttle_duration_sec=1.0)

    def on_joints(self, msg: JointState) -> None:
        try:
            self.controller.joints = joint_sample(stamp_to_seconds(msg.header.stamp), msg.name, msg.position, msg.velocity)
        except StateError as error:
            self.get_logger().warning(f"ignored: {error}", throttle_duration_sec=1.0)

    def on_tick(self) -> None:
        now = self.get_clock().now().nanoseconds * 1e-9
        command, reason = self.controller.step(now)
        if reason is not None:
            self.get_logger().warning(f"holding the rods: {reason}", throttle_duration_sec=2.0)
        self.command_pub.publish(Float64MultiArray(data=[float(c) for c in command]))

    def report_latency(self) -> None:
        stats = self.controller.latency_stats()
        if stats:
            self.latency_pub.publish(Float64(data=stats["median_ms"]))
            self.get_logger().info(
                f"inference latency over {stats['n']} steps: median {stats['median_ms']:.2f} ms, "
                f"p95 {stats['p95_ms']:.2f} ms, max {stats['max_ms']:.2f} ms")

    def stop_rods(self) -> None:
        """A last zero command on the way out, so the drives stop now rather than at the table's watchdog.
        It waits for the subscribers (the drives, a recorder) to acknowledge it: a sample still queued, or
        lost and due to be sent again, goes out only from a publisher that still exists."""
        if rclpy.ok():
            self.command_pub.publish(Float64MultiArray(data=[0.0] * COMMAND_SIZE))
            if not self.command_pub.wait_for_all_acked(Duration(seconds=STOP_ACK_TIMEOUT_S)):
                self.get_logger().warning(f"the last zero command was not acknowledged within "
                                          f"{STOP_ACK_TIMEOUT_S:g} s; the table's command watchdog stops the rods")


def main(args=None) -> int:
    return run_node("policy_node", PolicyNode, errors=(PolicyError, ValueError, TypeError), on_exit=PolicyNode.stop_rods, args=args)


if __name__ == "__main__":
    sys.exit(main())
