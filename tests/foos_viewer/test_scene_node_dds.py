"""sim_node -> scene_node -> a Foxglove WebSocket client, each started as a user starts it (ROS_DOMAIN_ID 100).

A probe node hears the same /ball/state, /ball/detection and /joint_states as scene_node, and sends the rod
command; the client checks every scene update against the message with the same stamp, and measures the
update rate and the latency from the probe's arrival of a message to the client's arrival of its update.
"""
import time

import numpy as np
import pytest
import rclpy
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import JointState
from std_msgs.msg import Float64MultiArray

from foos_core.names import JOINT_NAMES, RODS, TEAMS, command_topic, rod_name
from foos_core.table_params import load_params
from foos_viewer.live import BALL_TOPIC, DETECTIONS_TOPIC, RODS_TOPIC, SCENE_TOPICS, TABLE_TOPIC
from foos_viewer.scene import rod_entity_id, stamp_text

from .helpers import PORT_IN_LOG, FoxgloveClient, NodeProcess, entities, metadata, xyz
from .test_live_scene import expected_foot_centres, feet

pytestmark = pytest.mark.dds
DOMAIN = 100
MAX_RATE = 30.0
WINDOW_S = 3.0


class Listener:
    """The probe: what arrived on the contract's topics, by stamp, with its monotonic arrival time."""

    def __init__(self, domain: int):
        self.context = rclpy.Context()
        rclpy.init(context=self.context, domain_id=domain)
        self.node = rclpy.create_node("scene_probe", context=self.context)
        self.executor = SingleThreadedExecutor(context=self.context)
        self.executor.add_node(self.node)
        self.by_stamp: dict[str, dict] = {"state": {}, "detection": {}, "joints": {}}
        for key, kind, topic in (("state", Odometry, "/ball/state"), ("detection", PointStamped, "/ball/detection"),
                                 ("joints", JointState, "/joint_states")):
            self.node.create_subscription(kind, topic, lambda msg, key=key: self._keep(key, msg), 100)
        self.command_pub = self.node.create_publisher(Float64MultiArray, command_topic("home"), 10)

    def _keep(self, key: str, msg) -> None:
        self.by_stamp[key][stamp_text(msg.header.stamp.sec, msg.header.stamp.nanosec)] = (time.monotonic(), msg)

    def spin(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            self.executor.spin_once(timeout_sec=0.005)

    def spin_until(self, done, timeout: float) -> None:
        """Spin until done() holds or timeout s have passed (the caller checks which)."""
        end = time.monotonic() + timeout
        while not done() and time.monotonic() < end:
            self.spin(0.05)

    def close(self) -> None:
        self.executor.shutdown()  # it lets go of the node first, before the node's entities go
        self.node.destroy_node()
        rclpy.shutdown(context=self.context)


def percentile(values, q):
    return float(np.percentile(np.asarray(values) * 1000.0, q))


@pytest.fixture(scope="module")
def running():
    """sim_node on real time, serving a new rolling ball whenever one rests or scores, and scene_node on any free port."""
    sim = NodeProcess(DOMAIN, "foos_sim", "sim_node", "serve:=random", "seed:=3", "command_timeout:=0.3")
    viewer = NodeProcess(DOMAIN, "foos_viewer", "scene_node", "port:=0", f"max_rate:={MAX_RATE}")
    probe = Listener(DOMAIN)
    client = None
    try:
        port = int(viewer.wait_for_line(PORT_IN_LOG).group(1))
        client = FoxgloveClient(f"ws://127.0.0.1:{port}")
        client.subscribe(SCENE_TOPICS)
        yield sim, viewer, probe, client
    finally:
        if client is not None:
            client.close()
        probe.close()
        for process in (viewer, sim):
            process.stop()


@pytest.mark.timeout(180)
def test_the_scene_follows_sim_node_and_the_rods_move_on_command(running):
    sim, viewer, probe, client = running
    params = load_params()
    # until the probe has heard sim_node for a second (discovery, start-up)
    probe.spin_until(lambda: min(len(kind) for kind in probe.by_stamp.values()) >= 100, 30.0)
    client.wait_for(TABLE_TOPIC)
    first_rods = entities(client.wait_for(RODS_TOPIC)[-1][1], "rod/")
    figures = {key: len(entity.cubes) // 2 for key, entity in first_rods.items()}
    assert sorted(figures) == sorted(rod_entity_id(team, rod) for team in TEAMS for rod in RODS)
    assert sum(figures.values()) == 22
    assert all(figures[rod_entity_id(t, r)] == params["rods"]["layout"][rod_name(t, r)]["figures"] for t in TEAMS for r in RODS)

    # A window of updates: each one carries the stamp of the message it shows; the same stamp's message on
    # the probe has the same ball, detection and joint positions.
    start = time.monotonic()
    probe.spin(WINDOW_S)
    probe.spin(0.3)  # messages the probe had not taken yet
    latencies = {topic: [] for topic in (RODS_TOPIC, BALL_TOPIC, DETECTIONS_TOPIC)}
    rates = {}
    for topic, key in ((BALL_TOPIC, "state"), (DETECTIONS_TOPIC, "detection"), (RODS_TOPIC, "joints")):
        updates = [(t, u) for t, u in client.messages(topic, since=start) if t < start + WINDOW_S]
        rates[topic] = len(updates) / WINDOW_S
        for arrived, update in updates:
            for entity in update.entities:
                stamp = metadata(entity)["stamp"]
                assert stamp in probe.by_stamp[key], f"{topic} shows stamp {stamp}, which the probe never heard"
                heard, msg = probe.by_stamp[key][stamp]
                if key == "state":
                    p = msg.pose.pose.position
                    assert xyz(entity.spheres[0].pose.position) == pytest.approx((p.x, p.y, p.z), abs=1e-9)
                elif key == "detection":
                    assert xyz(entity.spheres[0].pose.position) == pytest.approx((msg.point.x, msg.point.y, msg.point.z), abs=1e-9)
                else:
                    positions = dict(zip(msg.name, msg.position))
                    team, rod = entity.id.removeprefix("rod/").split("_", 1)
                    slide, rotate = positions[f"{team}_{rod}_slide"], positions[f"{team}_{rod}_rotate"]
                    assert feet(entity) == pytest.approx(expected_foot_centres(params, team, rod, slide, rotate), abs=1e-9)
            latencies[topic].append(arrived - heard)
    balls = [xyz(entities(u)["ball"].spheres[0].pose.position) for _, u in client.messages(BALL_TOPIC, since=start)]
    assert np.ptp(np.array(balls)[:, 0]) > 0.05, "the ball was rolling during the window"
    for topic in latencies:
        print(f"{topic}: {rates[topic]:.1f} updates/s over {WINDOW_S:g} s; latency after the probe heard it: "
              f"median {percentile(latencies[topic], 50):.1f} ms, p95 {percentile(latencies[topic], 95):.1f} ms, "
              f"max {percentile(latencies[topic], 100):.1f} ms")
        assert 0.8 * MAX_RATE <= rates[topic] <= 1.05 * MAX_RATE, f"{topic}: {rates[topic]:.1f} updates/s"
        assert percentile(latencies[topic], 50) < 50.0

    # The home attack rotates on command; the scene shows it, and no other rod moves.
    before = max(probe.by_stamp["joints"].values(), key=lambda heard: heard[0])[1]
    rotate_index = JOINT_NAMES.index("home_attack_rotate")
    command = [0.0] * 8
    command[7] = 5.0  # home attack rotate, rad/s
    sent = time.monotonic()
    while time.monotonic() - sent < 0.6:
        probe.command_pub.publish(Float64MultiArray(data=command))
        probe.spin(0.05)
    probe.spin(1.0)  # the watchdog stops the rod 0.3 s after the last command
    rods = entities(client.messages(RODS_TOPIC)[-1][1], "rod/")
    moved = rods[rod_entity_id("home", "attack")]
    assert float(metadata(moved)["rotate"]) - before.position[rotate_index] > 1.5
    # The scene may show a message newer than the probe has taken so far (both hear sim_node at 100 Hz).
    shown_stamp = metadata(moved)["stamp"]
    probe.spin_until(lambda: shown_stamp in probe.by_stamp["joints"], 2.0)
    assert shown_stamp in probe.by_stamp["joints"], f"{RODS_TOPIC} shows stamp {shown_stamp}, which the probe never heard"
    _, latest = probe.by_stamp["joints"][shown_stamp]
    slide, rotate = latest.position[JOINT_NAMES.index("home_attack_slide")], latest.position[rotate_index]
    assert feet(moved) == pytest.approx(expected_foot_centres(params, "home", "attack", slide, rotate), abs=1e-9)
    assert not np.allclose(feet(moved), feet(first_rods[rod_entity_id("home", "attack")]), atol=0.01)
    # The others were not commanded: only the ball's hits turn them, by far less.
    for team in TEAMS:
        for rod in RODS:
            if (team, rod) != ("home", "attack"):
                assert abs(latest.position[JOINT_NAMES.index(f"{rod_name(team, rod)}_rotate")]) < 0.2
                assert float(metadata(rods[rod_entity_id(team, rod)])["rotate"]) == pytest.approx(
                    latest.position[JOINT_NAMES.index(f"{rod_name(team, rod)}_rotate")], abs=1e-6)
    assert sim.process.poll() is None and viewer.process.poll() is None
    assert viewer.stop() == 0
    assert any("scene updates sent: /scene/table" in line for line in viewer.lines), viewer.lines
