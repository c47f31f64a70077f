"""foos_bag's readers and writers without ROS running: array round trips, independent readers, splitting, bad input, repair."""
from __future__ import annotations

import os
import shutil
import signal
import sqlite3
import subprocess
import sys

import numpy as np
import pytest
from geometry_msgs.msg import PointStamped
from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rclpy.serialization import deserialize_message

from foos_bag import (
    FLOAT64_MULTI_ARRAY,
    STRING,
    BagError,
    BagWriter,
    messages,
    read_ball_detections,
    read_ball_states,
    read_commands,
    read_goals,
    read_joint_states,
    topics,
    typestore,
    write_ball_detections,
    write_ball_states,
    write_joint_states,
)
from foos_bag.repair import reindex
from foos_core.names import GOAL_TOPIC

from .helpers import BAGS, run_cli

JOINTS = [f"home_rod{i}_slide" for i in range(16)]


def sample_arrays(n=240, seed=0):
    rng = np.random.default_rng(seed)
    t = 1.5 + np.arange(n) / 120.0
    pos = np.c_[rng.uniform(-0.3, 0.3, n), rng.uniform(-0.6, 0.6, n), np.full(n, 0.0175)]
    vel = rng.normal(0, 1, (n, 3))
    q = rng.normal(0, 0.1, (n, 16))
    dq = rng.normal(0, 1, (n, 16))
    return t, pos, vel, q, dq


def write_sample(path, storage="mcap", **kw):
    t, pos, vel, q, dq = sample_arrays()
    with BagWriter(path, storage, **kw) as bag:
        write_ball_detections(bag, t, pos, latency=0.025)
        write_ball_states(bag, t, pos, vel)
        write_joint_states(bag, t, JOINTS, q, dq)
        bag.add_topic("/home/rods/command", FLOAT64_MULTI_ARRAY)
        arr = typestore().types[FLOAT64_MULTI_ARRAY]
        layout = typestore().types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
        for i, ti in enumerate(t[:10]):
            bag.write("/home/rods/command", int(ti * 1e9), arr(layout=layout, data=np.full(8, float(i))))
        bag.add_topic(GOAL_TOPIC, STRING)
        bag.write(GOAL_TOPIC, int(3e9), typestore().types[STRING](data="home"))
    return t, pos, vel, q, dq


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_arrays_round_trip(tmp_path, storage):
    t, pos, vel, q, dq = write_sample(tmp_path / "b", storage)
    det = read_ball_detections(tmp_path / "b")
    assert det.frame_id == "table"
    np.testing.assert_allclose(det.t, t, atol=1e-9)
    np.testing.assert_array_equal(det.position, pos)
    st = read_ball_states(tmp_path / "b")
    np.testing.assert_array_equal(st.position, pos)
    np.testing.assert_array_equal(st.velocity, vel)
    js = read_joint_states(tmp_path / "b")
    assert js.names == JOINTS
    np.testing.assert_array_equal(js.position, q)
    np.testing.assert_array_equal(js.velocity, dq)
    assert np.isnan(js.effort).all()
    cmd = read_commands(tmp_path / "b", "home")
    assert cmd.values.shape == (10, 8) and cmd.values[3, 0] == 3.0
    gt, teams = read_goals(tmp_path / "b")
    assert teams == ["home"] and gt[0] == 3.0
    counts = topics(tmp_path / "b")
    assert counts["/ball/detection"] == ("geometry_msgs/msg/PointStamped", len(t))
    # Receive time = capture stamp + latency, the order a recorder would have seen them in.
    recv = [ns for _, ns, _ in messages(tmp_path / "b", ["/ball/detection"])]
    np.testing.assert_allclose(np.array(recv) * 1e-9, t + 0.025, atol=1e-9)


def test_reader_sorts_by_stamp_and_accepts_late_arrivals(tmp_path):
    t = np.array([1.0, 1.1, 1.2, 1.3])
    latency = np.array([0.3, 0.0, 0.0, 0.0])  # the first capture arrives last
    with BagWriter(tmp_path / "b") as bag:
        write_ball_detections(bag, t, np.zeros((4, 3)) + t[:, None], latency=latency)
    det = read_ball_detections(tmp_path / "b")
    np.testing.assert_allclose(det.t, t)
    np.testing.assert_allclose(det.position[:, 0], t)


def test_mcap_opens_in_the_mcap_library_with_the_same_values(tmp_path):
    t, pos, vel, q, dq = write_sample(tmp_path / "b", "mcap")
    (mcap_file,) = (tmp_path / "b").glob("*.mcap")
    with open(mcap_file, "rb") as f:
        reader = make_reader(f, decoder_factories=[DecoderFactory()])
        assert reader.get_header().profile == "ros2"
        got = {"/ball/detection": [], "/joint_states": [], "/ball/state": []}
        for _schema, channel, message, decoded in reader.iter_decoded_messages(topics=list(got)):
            got[channel.topic].append((message.log_time, decoded))
    det = got["/ball/detection"]
    assert len(det) == len(t)
    np.testing.assert_allclose([d.header.stamp.sec + d.header.stamp.nanosec * 1e-9 for _, d in det], t, atol=1e-9)
    np.testing.assert_array_equal([[d.point.x, d.point.y, d.point.z] for _, d in det], pos)
    np.testing.assert_array_equal([d.position for _, d in got["/joint_states"]], q)
    np.testing.assert_array_equal([list(d.name) for _, d in got["/joint_states"]][0], JOINTS)
    np.testing.assert_array_equal(
        [[d.twist.twist.linear.x, d.twist.twist.linear.y, d.twist.twist.linear.z] for _, d in got["/ball/state"]], vel
    )


def test_db3_opens_in_plain_sqlite3_and_decodes_with_rclpy(tmp_path):
    t, pos, *_ = write_sample(tmp_path / "b", "sqlite3")
    (db_file,) = (tmp_path / "b").glob("*.db3")
    db = sqlite3.connect(db_file)
    (topic_id,) = db.execute("SELECT id FROM topics WHERE name = '/ball/detection'").fetchone()
    assert db.execute("SELECT type FROM topics WHERE id = ?", (topic_id,)).fetchone()[0] == "geometry_msgs/msg/PointStamped"
    rows = db.execute("SELECT timestamp, data FROM messages WHERE topic_id = ? ORDER BY timestamp", (topic_id,)).fetchall()
    msgs = [deserialize_message(data, PointStamped) for _, data in rows]
    np.testing.assert_array_equal([[m.point.x, m.point.y, m.point.z] for m in msgs], pos)
    np.testing.assert_allclose([m.header.stamp.sec + m.header.stamp.nanosec * 1e-9 for m in msgs], t, atol=1e-9)
    assert db.execute("SELECT COUNT(*) FROM message_definitions").fetchone()[0] >= 3


@pytest.mark.parametrize("fixture", ["rosbag2_spec_mcap", "rosbag2_spec_sqlite3"])
def test_reads_bags_written_by_other_implementations(fixture):
    det = read_ball_detections(BAGS / fixture)
    assert len(det.t) == 120 and det.frame_id == "table"
    np.testing.assert_allclose(det.position[5], [0.105, -0.19, 0.0175])
    assert np.all(np.diff(det.t) > 0)
    js = read_joint_states(BAGS / fixture)  # Fast DDS CDR with trailing padding
    assert js.names == ["home_goalie_slide", "home_goalie_rotate"]
    np.testing.assert_allclose(js.position[10], [0.1, -0.2])


def test_split_by_size_and_duration(tmp_path):
    t, pos, *_ = sample_arrays(n=600)
    with BagWriter(tmp_path / "size", max_bag_size=8000) as bag:
        write_ball_detections(bag, t, pos)
    files = sorted(p.name for p in (tmp_path / "size").glob("*.mcap"))
    assert len(files) >= 3 and files[0] == "size_0.mcap"
    np.testing.assert_array_equal(read_ball_detections(tmp_path / "size").position, pos)
    with BagWriter(tmp_path / "dur", "sqlite3", max_bag_duration=1.0) as bag:
        write_ball_detections(bag, t, pos)  # 5 s of data
    assert len(list((tmp_path / "dur").glob("*.db3"))) == 5
    np.testing.assert_allclose(read_ball_detections(tmp_path / "dur").t, t, atol=1e-9)


def test_refuses_to_overwrite_and_rejects_bad_input(tmp_path):
    (tmp_path / "exists").mkdir()
    with pytest.raises(BagError, match="exists already"):
        BagWriter(tmp_path / "exists")
    with BagWriter(tmp_path / "b") as bag:
        with pytest.raises(BagError, match="NaN"):
            write_ball_detections(bag, [0.0, 1.0], [[0, 0, 0], [np.nan, 0, 0]])
        with pytest.raises(BagError, match="shape"):
            write_ball_detections(bag, [0.0, 1.0], [[0, 0, 0]])
        with pytest.raises(BagError, match=">= 0"):
            write_ball_detections(bag, [-1.0], [[0, 0, 0]])
        with pytest.raises(BagError, match="add_topic"):
            bag.write_raw("/nope", 0, b"\x00\x01\x00\x00")
        with pytest.raises(BagError, match="unknown message type"):
            bag.add_topic("/x", "nopkg/msg/Nothing")
        write_ball_detections(bag, [0.5], [[0.1, 0.2, 0.0175]])
    assert topics(tmp_path / "b") == {"/ball/detection": ("geometry_msgs/msg/PointStamped", 1)}


def test_clear_errors_for_missing_corrupt_and_truncated_bags(tmp_path):
    with pytest.raises(BagError, match="no such bag"):
        read_ball_detections(tmp_path / "missing")
    (tmp_path / "empty").mkdir()
    with pytest.raises(BagError, match="not a bag"):
        topics(tmp_path / "empty")
    write_sample(tmp_path / "b")
    with pytest.raises(BagError, match="no topic /ball/missing"):
        read_ball_detections(tmp_path / "b", topic="/ball/missing")
    # Truncated: the MCAP summary and footer are gone.
    shutil.copytree(tmp_path / "b", tmp_path / "cut")
    (mcap_file,) = (tmp_path / "cut").glob("*.mcap")
    data = mcap_file.read_bytes()
    mcap_file.write_bytes(data[: len(data) * 2 // 3])
    with pytest.raises(BagError, match="corrupt or truncated"):
        read_ball_detections(tmp_path / "cut")
    # Garbage where the storage file should be.
    shutil.copytree(tmp_path / "b", tmp_path / "junk")
    (mcap_file,) = (tmp_path / "junk").glob("*.mcap")
    mcap_file.write_bytes(os.urandom(5000))
    with pytest.raises(BagError, match="corrupt or truncated"):
        topics(tmp_path / "junk")
    write_sample(tmp_path / "d", "sqlite3")
    (db_file,) = (tmp_path / "d").glob("*.db3")
    db_file.write_bytes(db_file.read_bytes()[:3000])
    with pytest.raises(BagError, match="corrupt or truncated"):
        read_ball_detections(tmp_path / "d")


KILLED_WRITER = r"""
import os, signal, sys, time
import numpy as np
from foos_bag import POINT_STAMPED, BagWriter, typestore
from foos_bag.message_types import header
bag = BagWriter(sys.argv[1], sys.argv[2], flush_interval=0.05, max_bag_size=int(sys.argv[3]))
bag.add_topic("/ball/detection", POINT_STAMPED)
PS = typestore().types[POINT_STAMPED]
P = typestore().types["geometry_msgs/msg/Point"]
for i in range(400):
    bag.write("/ball/detection", 1_000_000 + i, PS(header=header(i * 0.01, "table"), point=P(x=float(i), y=0.0, z=0.0)))
    time.sleep(0.001)
bag.flush()
print("flushed", flush=True)
for i in range(400, 420):  # written but never flushed: lost by design
    bag.write("/ball/detection", 1_000_000 + i, PS(header=header(i * 0.01, "table"), point=P(x=float(i), y=0.0, z=0.0)))
os.kill(os.getpid(), signal.SIGKILL)
"""


@pytest.mark.parametrize("storage,split", [("mcap", 0), ("sqlite3", 0), ("mcap", 6000)])
def test_reindex_after_sigkill_recovers_all_flushed_messages(tmp_path, storage, split):
    proc = subprocess.run([sys.executable, "-c", KILLED_WRITER, str(tmp_path / "k"), storage, str(split)],
                          capture_output=True, text=True)
    assert proc.returncode == -signal.SIGKILL and "flushed" in proc.stdout, proc.stderr
    if split:  # metadata.yaml exists from the last split but misses the file being written
        assert (tmp_path / "k" / "metadata.yaml").exists()
    with pytest.raises(BagError, match="reindex"):
        read_ball_detections(tmp_path / "k")
    reports = reindex(tmp_path / "k")
    assert len(reports) > (2 if split else 0)
    assert sum(r.messages for r in reports) >= 400
    x = read_ball_detections(tmp_path / "k").position[:, 0]
    np.testing.assert_array_equal(x[:400], np.arange(400))
    assert np.all(np.diff(x) == 1)


def test_repair_of_a_file_cut_at_any_byte_keeps_complete_messages(tmp_path):
    with BagWriter(tmp_path / "src", flush_interval=1e9) as bag:
        bag._storage.chunk_bytes = 2000  # many small chunks, as a recorder flushing often writes
        t, pos, *_ = sample_arrays(n=300)
        write_ball_detections(bag, t, pos)
    (src,) = (tmp_path / "src").glob("*.mcap")
    data = src.read_bytes()
    previous = -1
    for fraction in (0.2, 0.5, 0.77, 0.93):
        cut = tmp_path / f"cut{fraction}"
        cut.mkdir()
        (cut / src.name).write_bytes(data[: int(len(data) * fraction)])
        report = reindex(cut)[0]
        assert report.status == "recovered" and (cut / (src.name + ".broken")).exists()
        det = read_ball_detections(cut)
        n = len(det.t)
        assert n > previous  # a longer file never yields fewer messages
        np.testing.assert_array_equal(det.position, pos[:n])  # a prefix, byte-exact
        previous = n
    assert previous >= 250
    # An uncompressed chunk cut mid-way still gives its complete messages: the 50% cut keeps more
    # than the chunks that were whole.
    with pytest.raises(BagError, match="not an MCAP"):
        (tmp_path / "bad").mkdir()
        (tmp_path / "bad" / "bad_0.mcap").write_bytes(b"garbage" * 10)
        reindex(tmp_path / "bad")


def test_info_and_cli_errors_are_one_line(tmp_path):
    write_sample(tmp_path / "b")
    info = run_cli(["ros2", "bag", "info", "b"], tmp_path)
    assert info.returncode == 0, info.stderr
    assert "Topic: /ball/detection | Type: geometry_msgs/msg/PointStamped | Count: 240" in info.stdout
    assert "Storage id:        mcap" in info.stdout
    for args in (["info", "missing"], ["play", "missing"], ["reindex", "missing"], ["record", "/a", "-o", "b"],
                 ["play", "b", "--topics", "/nope"], ["play", "b", "--remap", "bad"]):
        r = run_cli(["ros2", "bag", *args], tmp_path)
        assert r.returncode != 0, args
        assert len(r.stderr.strip().splitlines()) == 1 and "Traceback" not in r.stderr, (args, r.stderr)
    r = run_cli(["ros2", "bag", "record", "--help"], tmp_path)
    assert r.returncode == 0 and "--max-bag-size" in r.stdout
