"""sim_node as a user runs it (`ros2 run foos_sim sim_node`), probed by a real rclpy node over DDS."""
import math
import os
import signal
import subprocess
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from rclpy.node import Node
from rosgraph_msgs.msg import Clock
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray
from std_srvs.srv import Trigger

from foos_core.names import JOINT_NAMES

# Every test here starts nodes that talk over DDS.
pytestmark = pytest.mark.dds

# This file's ROS_DOMAIN_ID; other test areas use other ranges. One probe context serves the whole
# module (tests run one after another, each with its own sim_node), because creating and shutting
# down many rclpy contexts in one process is where rclpy has crashed on us.
DOMAIN = 10


class SimNodeProcess:
    def __init__(self, domain: int, *params: str):
        self.env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
        args = ["ros2", "run", "foos_sim", "sim_node", "--ros-args"]
        for p in params:
            args += ["-p", p]
        self.process = subprocess.Popen(args, env=self.env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        text=True, start_new_session=True)

    def output(self) -> str:
        return self.process.communicate(timeout=10)[0]

    def stop(self):
        """Ctrl-C, then SIGKILL if needed. A killed node's DDS reader lingers until its lease expires and
        stalls our reliable command publisher meanwhile, so the next test's commands would not arrive."""
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGINT)
            try:
                self.process.wait(timeout=5)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()


class Probe:
    """A test node in its own context and domain that records what sim_node publishes."""

    def __init__(self, domain: int):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = Node("probe", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.received = {"joints": [], "state": [], "detection": [], "clock": []}
        self.node.create_subscription(JointState, "/joint_states", lambda m: self._keep("joints", m), 50)
        self.node.create_subscription(Odometry, "/ball/state", lambda m: self._keep("state", m), 50)
        self.node.create_subscription(PointStamped, "/ball/detection", lambda m: self._keep("detection", m), 50)
        self.node.create_subscription(Clock, "/clock", lambda m: self._keep("clock", m), 50)
        self.commands = {team: self.node.create_publisher(Float64MultiArray, f"/{team}/rods/command", 10)
                         for team in ("home", "away")}

    def clear(self):
        for messages in self.received.values():
            messages.clear()

    def _keep(self, key, msg):
        self.received[key].append((time.monotonic(), msg))

    def spin(self, seconds: float, until=None):
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.01)
            if until is not None and until():
                return True
        return False

    def wait_for_sim(self, timeout=30.0):
        """Until sim_node publishes to us and its command subscriptions have matched our publishers."""
        def matched():
            return len(self.received["joints"]) > 3 and all(
                pub.get_subscription_count() > 0 for pub in self.commands.values())
        assert self.spin(timeout, until=matched), "sim_node did not come up (no states, or no command subscription)"

    def command(self, team, values):
        self.commands[team].publish(Float64MultiArray(data=[float(v) for v in values]))

    def close(self):
        # Executor first, then the node's entities, then the context: destroying a node that an executor
        # still waits on can crash rclpy.
        self.executor.remove_node(self.node)
        self.executor.shutdown()
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


@pytest.fixture(scope="module")
def module_probe():
    p = Probe(DOMAIN)
    yield p
    p.close()


@pytest.fixture
def domain():
    return DOMAIN


@pytest.fixture
def probe(module_probe):
    # Take what the previous test's sim_node left in our readers' queues before forgetting it: a message
    # taken later would pass for one of this test's node (seen once: a real-time stamp among sim-time ones).
    module_probe.spin(0.3)
    module_probe.clear()
    return module_probe


def latest_joints(probe):
    msg = probe.received["joints"][-1][1]
    assert list(msg.name) == list(JOINT_NAMES)
    return np.array(msg.position), np.array(msg.velocity)


@pytest.mark.timeout(120)
def test_one_rod_command_moves_only_that_joint_and_ball_state_keeps_its_rate(domain, probe):
    sim = SimNodeProcess(domain, "serve:=none", "ball_x:=0.2", "ball_y:=0.1", "publish_rate:=50.0", "command_timeout:=0.3")
    try:
        probe.wait_for_sim()
        before, _ = latest_joints(probe)
        command = np.zeros(8)
        command[3] = 5.0  # home defence rotate, rad/s
        t_command = time.monotonic()
        while time.monotonic() - t_command < 1.0:
            probe.command("home", command)
            probe.spin(0.05)
        after, velocity = latest_joints(probe)
        moved = JOINT_NAMES.index("home_defence_rotate")
        assert velocity[moved] == pytest.approx(5.0, rel=0.05)
        assert after[moved] - before[moved] > 2.0
        others = [i for i in range(16) if i != moved]
        assert np.max(np.abs(after[others] - before[others])) < 1e-3
        assert np.max(np.abs(velocity[others])) < 1e-2
        # The watchdog stops the rod once its commands stop.
        probe.spin(1.0)
        _, velocity = latest_joints(probe)
        assert abs(velocity[moved]) < 0.05
        # Ball state at the configured rate, measured over 2 s of arrivals.
        start = time.monotonic()
        probe.spin(2.0)
        arrivals = [t for t, _ in probe.received["state"] if t >= start]
        assert len(arrivals) / 2.0 == pytest.approx(50.0, rel=0.2)
        position = probe.received["state"][-1][1].pose.pose.position
        assert (position.x, position.y) == pytest.approx((0.2, 0.1), abs=1e-3)
        assert probe.received["state"][-1][1].header.frame_id == "table"
    finally:
        sim.stop()


@pytest.mark.timeout(120)
def test_nan_and_wrong_length_commands_are_refused_and_the_node_lives_on(domain, probe):
    sim = SimNodeProcess(domain, "serve:=none")
    try:
        probe.wait_for_sim()
        for _ in range(5):
            probe.command("home", [math.nan] + [0.0] * 7)
            probe.command("away", [1.0] * 7)
            probe.spin(0.05)
        assert sim.process.poll() is None, "sim_node died on a bad command"
        _, velocity = latest_joints(probe)
        assert np.max(np.abs(velocity)) < 1e-3, "a refused command must not move a rod"
        good = np.zeros(8)
        good[0] = 0.05  # home goalie slide, slow enough to stay clear of its travel stop
        for _ in range(10):
            probe.command("home", good)
            probe.spin(0.05)
        _, velocity = latest_joints(probe)
        assert velocity[JOINT_NAMES.index("home_goalie_slide")] == pytest.approx(0.05, rel=0.05)
        os.killpg(sim.process.pid, signal.SIGINT)
        log = sim.output()
        assert "NaN" in log and "refused" in log
        assert "8 values, got 7" in log
    finally:
        sim.stop()


@pytest.mark.timeout(120)
def test_ctrl_c_ends_the_node_within_two_seconds(domain, probe):
    sim = SimNodeProcess(domain)
    try:
        probe.wait_for_sim()
        start = time.monotonic()
        os.killpg(sim.process.pid, signal.SIGINT)
        sim.process.wait(timeout=5)
        assert time.monotonic() - start < 2.0
        assert sim.process.returncode == 0
    finally:
        sim.stop()


@pytest.mark.timeout(120)
def test_sim_time_clock_detections_and_reset_service(domain, probe):
    sim = SimNodeProcess(domain, "publish_clock:=true", "real_time_factor:=0", "detection_noise:=0.002",
                         "detection_latency:=0.02", "detection_dropout:=0.1")
    try:
        probe.wait_for_sim()
        probe.spin(2.0)
        clocks = [m.clock.sec + m.clock.nanosec * 1e-9 for _, m in probe.received["clock"]]
        assert len(clocks) > 10 and np.all(np.diff(clocks) > 0), "/clock runs forward"
        assert clocks[0] < 1000.0, "sim time starts near zero"
        stamps = [m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for _, m in probe.received["detection"]]
        # Detection stamps are simulated capture times: on the /clock time base, increasing. (Arrival order
        # across topics is not defined, so they are not compared message by message with /clock.)
        assert len(stamps) > 10 and np.all(np.diff(stamps) > 0)
        assert max(stamps) < max(clocks) + 1.0
        assert all(m.header.frame_id == "table" for _, m in probe.received["detection"])
        client = probe.node.create_client(Trigger, "/sim/reset")
        try:
            assert client.wait_for_service(timeout_sec=10.0)
            future = client.call_async(Trigger.Request())
            probe.spin(10.0, until=future.done)
            assert future.done() and future.result().success
        finally:
            probe.node.destroy_client(client)
    finally:
        sim.stop()


def test_bad_parameters_give_a_one_line_error(domain):
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain))
    for params, message in ((["params_file:=/nonexistent/table.yaml"], "not found"),
                            (["serve:=kickoff"], "serve must be one of"),
                            (["real_time_factor:=0"], "needs publish_clock"),
                            (["camera_rate:=-30.0"], "camera_rate must be"),
                            (["camera_rate:=30.0", "camera:=/nonexistent/camera.yaml"], "camera config not found"),
                            (["camera_rate:=30.0", "camera_width:=4"], "at least 16")):
        args = ["ros2", "run", "foos_sim", "sim_node", "--ros-args"] + [a for p in params for a in ("-p", p)]
        result = subprocess.run(args, env=env, capture_output=True, text=True, timeout=60)
        assert result.returncode != 0
        assert message in result.stderr
        assert "Traceback" not in result.stderr and len(result.stderr.strip().splitlines()) == 1
