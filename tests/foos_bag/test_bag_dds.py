"""Record and play over real DDS: a sim_node round trip, player options, the recorder as a node."""
from __future__ import annotations

import signal
import time
from collections import defaultdict

import numpy as np
import pytest

from foos_bag import messages, read_ball_detections, topics

from .helpers import BAGS

pytestmark = pytest.mark.dds

SIM_TOPICS = ["/joint_states", "/ball/state", "/ball/detection", "/sim/goal"]


def raw_by_topic(bag, topic_names=None):
    out = defaultdict(list)
    for topic, ns, cdr in messages(bag, topic_names, raw=True):
        out[topic].append((ns, bytes(cdr)))
    return out


@pytest.mark.timeout(150)
def test_sim_node_round_trip_record_play_record(launch, tmp_path):
    # 1. Record a 10 s sim_node run.
    rec_a = launch(["ros2", "bag", "record", *SIM_TOPICS, "-o", "A"], "rec_a", 25)
    rec_a.wait_for("Recording", 30)
    sim = launch(["ros2", "run", "foos_sim", "sim_node", "--ros-args", "-p", "seed:=3", "-p", "detection_noise:=0.002"],
                 "sim", 25)
    rec_a.wait_for("Subscribed to topic", 60, count=len(SIM_TOPICS))
    time.sleep(10.0)
    rec_a.signal(signal.SIGINT)
    assert rec_a.wait(20) == 0, rec_a.text()
    sim.stop()
    a = raw_by_topic(tmp_path / "A")
    assert len(a["/joint_states"]) > 500 and len(a["/ball/detection"]) > 600, {k: len(v) for k, v in a.items()}

    # 2. Play it into a second recorder (another domain, so nothing else can reach it).
    rec_b = launch(["ros2", "bag", "record", *SIM_TOPICS, "-o", "B"], "rec_b", 26)
    rec_b.wait_for("Recording", 30)
    player = launch(["ros2", "bag", "play", "A", "--wait-for-subscribers", "1"], "player", 26)
    assert player.wait(90) == 0, player.text()
    time.sleep(0.5)
    rec_b.signal(signal.SIGINT)
    assert rec_b.wait(20) == 0, rec_b.text()
    b = raw_by_topic(tmp_path / "B")

    # Same messages, byte for byte (so same contents and header stamps), in the same order, per topic.
    for topic in ("/joint_states", "/ball/state", "/ball/detection"):
        assert [cdr for _, cdr in b[topic]] == [cdr for _, cdr in a[topic]], topic
    assert [cdr for _, cdr in b.get("/sim/goal", [])] == [cdr for _, cdr in a.get("/sim/goal", [])]
    stamps_a = read_ball_detections(tmp_path / "A").t
    np.testing.assert_array_equal(read_ball_detections(tmp_path / "B").t, stamps_a)
    # Original timing: the replay spans the same time as the recording.
    span = lambda msgs: (msgs[-1][0] - msgs[0][0]) * 1e-9  # noqa: E731
    assert span(b["/joint_states"]) == pytest.approx(span(a["/joint_states"]), rel=0.1)


@pytest.mark.timeout(90)
def test_player_rate_filter_remap_clock_and_loop_on_a_foreign_bag(launch, tmp_path):
    fixture = BAGS / "rosbag2_spec_mcap"  # written by the mcap library to the rosbag2 spec, not by us
    rec = launch(["ros2", "bag", "record", "/replay/detection", "/replay/loop", "/clock", "-o", "R"], "rec", 27)
    rec.wait_for("Recording", 30)
    play = launch(["ros2", "bag", "play", str(fixture), "--topics", "/ball/detection", "--remap",
                   "/ball/detection:=/replay/detection", "--rate", "2", "--clock", "50",
                   "--wait-for-subscribers", "1"], "play", 27)
    assert play.wait(60) == 0, play.text()
    loop = launch(["ros2", "bag", "play", str(fixture), "--topics", "/ball/detection", "--remap",
                   "/ball/detection:=/replay/loop", "--rate", "4", "--loop", "--wait-for-subscribers", "1"], "loop", 27)
    rec.wait_for("Subscribed to topic '/replay/loop'", 30)
    time.sleep(2.0)
    loop.signal(signal.SIGINT)
    assert loop.wait(20) == 0, loop.text()
    time.sleep(0.3)
    rec.signal(signal.SIGINT)
    assert rec.wait(20) == 0, rec.text()

    original = [cdr for _, cdr in raw_by_topic(fixture, ["/ball/detection"])["/ball/detection"]]
    got = raw_by_topic(tmp_path / "R")
    replay = got["/replay/detection"]
    assert [cdr for _, cdr in replay] == original  # filtered (no /joint_states), remapped, complete
    span = (replay[-1][0] - replay[0][0]) * 1e-9
    assert 0.35 < span < 0.8, f"1 s of data at --rate 2 took {span:.2f} s"
    looped = [cdr for _, cdr in got["/replay/loop"]]
    assert len(looped) > len(original) + 10, "--loop did not start over"
    first = looped.index(original[0])
    assert looped[first : first + len(original)] == original
    assert looped[first + len(original)] == original[0]
    clock = messages(tmp_path / "R", ["/clock"])
    t = np.array([m.clock.sec + m.clock.nanosec * 1e-9 for _, _, m in clock])
    assert len(t) > 10
    det_t = read_ball_detections(fixture).t
    assert det_t[0] - 0.5 <= t.min() and t.max() <= det_t[-1] + 0.5  # /clock carries the bag's time
    assert np.all(np.diff(t) >= 0)


@pytest.mark.timeout(90)
def test_recorder_node_all_topics_picks_up_new_best_effort_topics(launch, tmp_path):
    rec = launch(["ros2", "run", "foos_bag", "recorder", "--ros-args", "-p", "all:=true", "-p", "output:=node_bag",
                  "-p", "storage:=sqlite3", "-p", "exclude_regex:=^/(rosout|parameter_events)$"], "rec", 28)
    rec.wait_for("Recording", 30)
    time.sleep(0.5)  # the topics appear after the recorder started
    pub = launch(["ros2", "run", "foos_bag", "load_publisher", "--best-effort", "--topics", "2", "--rate", "100",
                  "--duration", "3", "--wait-subscribers", "1", "--log", "pub.json"], "pub", 28)
    assert pub.wait(60) == 0, pub.text() + rec.text()
    time.sleep(0.3)
    rec.signal(signal.SIGTERM)
    assert rec.wait(20) == 0, rec.text()
    recorded = topics(tmp_path / "node_bag")
    assert set(recorded) == {"/load/t0", "/load/t1"}
    # A reliable subscription would match no best-effort publisher and get nothing; loopback loses little.
    assert all(n >= 270 for _, n in recorded.values()), recorded
    meta = (tmp_path / "node_bag" / "metadata.yaml").read_text()
    assert "reliability: best_effort" in meta
