#!/usr/bin/env python3
"""Build the rosbag2 fixtures in bags/ WITHOUT our writer, so our reader and player are tested on files
that another implementation produced.

No real ROS 2 installation (and so no real rosbag2) is reachable from this project's machines, so these
bags are built to the rosbag2 Jazzy spec with independent tools:
  * bags/rosbag2_spec_mcap: the `mcap` library's writer (zstd chunks, as the mcap CLI writes them),
    profile "ros2", schemas from the installed .msg files in rosbag2's concatenated `ros2msg` format,
    channel metadata `offered_qos_profiles`, and a version-9 metadata.yaml as rosbag2_storage writes it;
  * bags/rosbag2_spec_sqlite3: plain `sqlite3` with rosbag2's schema (schema_version 4).
CDR bytes come from rclpy's C type support (rclpy.serialization), not from rosbags.

Run from the repository root in the workspace environment: python tests/foos_bag/make_fixtures.py
It refuses to overwrite existing fixtures.
"""
from __future__ import annotations

import os
import sqlite3
import sys
from pathlib import Path

from geometry_msgs.msg import PointStamped
from mcap.writer import CompressionType, Writer
from rclpy.serialization import serialize_message
from sensor_msgs.msg import JointState

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"
T0 = 1_763_700_000_000_000_000  # ns, Nov 21 2025: a wall-clock time, as a real recording would have

QOS_V9 = """- history: keep_last
  depth: 10
  reliability: reliable
  durability: volatile
  deadline:
    sec: 9223372036
    nsec: 854775807
  lifespan:
    sec: 9223372036
    nsec: 854775807
  liveliness: automatic
  liveliness_lease_duration:
    sec: 9223372036
    nsec: 854775807
  avoid_ros_namespace_conventions: false"""

HASHES = {
    "geometry_msgs/msg/PointStamped": "RIHS01_4c0296af86e01e562e9e0405d138a01537247580076c58ea38d7923ac1045897",
}


def msg_file(msgtype: str) -> str:
    package, _, name = msgtype.partition("/msg/")
    for prefix in os.environ["AMENT_PREFIX_PATH"].split(os.pathsep):
        path = Path(prefix, "share", package, "msg", name + ".msg")
        if path.is_file():
            return path.read_text()
    raise SystemExit(f"no .msg file for {msgtype}")


BUILTIN = {"bool", "byte", "char", "float32", "float64", "int8", "uint8", "int16", "uint16", "int32",
           "uint32", "int64", "uint64", "string", "wstring"}


def dependencies(text: str, package: str) -> list[str]:
    """The non-builtin field types of a .msg text, as 'pkg/msg/Name'."""
    deps = []
    for line in text.splitlines():
        tokens = line.split("#")[0].split()
        if len(tokens) < 2:
            continue
        field_type = tokens[0].split("[")[0].split("<=")[0]
        if field_type in BUILTIN:
            continue
        if "/" not in field_type:
            field_type = "std_msgs/Header" if field_type == "Header" else f"{package}/{field_type}"
        deps.append(field_type.replace("/", "/msg/"))
    return deps


def ros2msg_definition(msgtype: str) -> str:
    """rosbag2's concatenated definition: the type's .msg text, then each dependency once."""
    text = msg_file(msgtype)
    seen, order, stack = set(), [], list(reversed(dependencies(text, msgtype.split("/")[0])))
    while stack:
        dep = stack.pop()
        if dep in seen:
            continue
        seen.add(dep)
        order.append(dep)
        stack.extend(reversed(dependencies(msg_file(dep), dep.split("/")[0])))
    parts = [text]
    for dep in order:
        parts.append("=" * 80 + "\nMSG: " + dep.replace("/msg/", "/") + "\n" + msg_file(dep))
    return "\n".join(parts)


def sample_messages():
    """Ball detections at 120 Hz for 1 s (capture stamps; received 25 ms later) and joint states at 50 Hz."""
    out = []
    for i in range(120):
        stamp = T0 + i * 8_333_333
        m = PointStamped()
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        m.header.frame_id = "table"
        m.point.x, m.point.y, m.point.z = 0.1 + 0.001 * i, -0.2 + 0.002 * i, 0.0175
        out.append(("/ball/detection", "geometry_msgs/msg/PointStamped", stamp + 25_000_000, serialize_message(m)))
    for i in range(50):
        stamp = T0 + i * 20_000_000
        m = JointState()
        m.header.stamp.sec, m.header.stamp.nanosec = divmod(stamp, 1_000_000_000)
        m.name = ["home_goalie_slide", "home_goalie_rotate"]
        m.position = [0.01 * i, -0.02 * i]
        m.velocity = [0.5, -1.0]
        out.append(("/joint_states", "sensor_msgs/msg/JointState", stamp, serialize_message(m)))
    out.sort(key=lambda m: m[2])
    return out


def metadata_yaml(storage: str, file_name: str, msgs) -> str:
    topics = {}
    for topic, msgtype, _, _ in msgs:
        topics.setdefault(topic, [msgtype, 0])[1] += 1
    start, end = msgs[0][2], msgs[-1][2]
    lines = [
        "rosbag2_bagfile_information:",
        "  version: 9",
        f"  storage_identifier: {storage}",
        "  duration:",
        f"    nanoseconds: {end - start}",
        "  starting_time:",
        f"    nanoseconds_since_epoch: {start}",
        f"  message_count: {len(msgs)}",
        "  topics_with_message_count:",
    ]
    qos = "\n".join("          " + line for line in QOS_V9.splitlines())
    for topic, (msgtype, n) in topics.items():
        lines += [
            "    - topic_metadata:",
            f"        name: {topic}",
            f"        type: {msgtype}",
            "        serialization_format: cdr",
            "        offered_qos_profiles:",
            qos,
            f"        type_description_hash: {HASHES.get(msgtype, '')}",
            f"      message_count: {n}",
        ]
    lines += [
        "  compression_format: \"\"",
        "  compression_mode: \"\"",
        "  relative_file_paths:",
        f"    - {file_name}",
        "  files:",
        f"    - path: {file_name}",
        "      starting_time:",
        f"        nanoseconds_since_epoch: {start}",
        "      duration:",
        f"        nanoseconds: {end - start}",
        f"      message_count: {len(msgs)}",
        "  custom_data: ~",
        "  ros_distro: jazzy",
    ]
    return "\n".join(lines) + "\n"


def make_mcap(bag: Path, msgs) -> None:
    bag.mkdir()
    name = bag.name + "_0.mcap"
    with open(bag / name, "wb") as f:
        w = Writer(f, compression=CompressionType.ZSTD, chunk_size=4096)
        w.start(profile="ros2", library="rosbag2 spec fixture (mcap python writer)")
        channels = {}
        for topic, msgtype, _, _ in msgs:
            if topic not in channels:
                sid = w.register_schema(name=msgtype, encoding="ros2msg", data=ros2msg_definition(msgtype).encode())
                channels[topic] = w.register_channel(
                    topic=topic, message_encoding="cdr", schema_id=sid,
                    metadata={"offered_qos_profiles": QOS_V9, "topic_type_hash": HASHES.get(msgtype, "")},
                )
        for seq, (topic, _, stamp, data) in enumerate(msgs):
            w.add_message(channel_id=channels[topic], log_time=stamp, publish_time=stamp, data=data, sequence=seq)
        w.finish()
    (bag / "metadata.yaml").write_text(metadata_yaml("mcap", name, msgs))


def make_sqlite(bag: Path, msgs) -> None:
    bag.mkdir()
    name = bag.name + "_0.db3"
    db = sqlite3.connect(bag / name)
    db.executescript(
        """
        CREATE TABLE schema(schema_version INTEGER PRIMARY KEY, ros_distro TEXT NOT NULL);
        CREATE TABLE metadata(id INTEGER PRIMARY KEY, metadata_version INTEGER NOT NULL, metadata TEXT NOT NULL);
        CREATE TABLE topics(id INTEGER PRIMARY KEY, name TEXT NOT NULL, type TEXT NOT NULL,
          serialization_format TEXT NOT NULL, offered_qos_profiles TEXT NOT NULL, type_description_hash TEXT NOT NULL);
        CREATE TABLE message_definitions(id INTEGER PRIMARY KEY, topic_type TEXT NOT NULL, encoding TEXT NOT NULL,
          encoded_message_definition TEXT NOT NULL, type_description_hash TEXT NOT NULL);
        CREATE TABLE messages(id INTEGER PRIMARY KEY, topic_id INTEGER NOT NULL, timestamp INTEGER NOT NULL,
          data BLOB NOT NULL);
        CREATE INDEX timestamp_idx ON messages (timestamp ASC);
        INSERT INTO schema VALUES (4, 'jazzy');
        """
    )
    ids = {}
    for topic, msgtype, _, _ in msgs:
        if topic not in ids:
            ids[topic] = len(ids) + 1
            db.execute("INSERT INTO topics VALUES (?, ?, ?, 'cdr', ?, ?)",
                       (ids[topic], topic, msgtype, QOS_V9, HASHES.get(msgtype, "")))
            db.execute("INSERT INTO message_definitions (topic_type, encoding, encoded_message_definition, "
                       "type_description_hash) VALUES (?, 'ros2msg', ?, ?)",
                       (msgtype, ros2msg_definition(msgtype), HASHES.get(msgtype, "")))
    db.executemany("INSERT INTO messages (topic_id, timestamp, data) VALUES (?, ?, ?)",
                   [(ids[t], stamp, data) for t, _, stamp, data in msgs])
    db.execute("INSERT INTO metadata (metadata_version, metadata) VALUES (9, ?)",
               (metadata_yaml("sqlite3", name, msgs),))
    db.commit()
    db.close()
    (bag / "metadata.yaml").write_text(metadata_yaml("sqlite3", name, msgs))


def main() -> None:
    msgs = sample_messages()
    for name, make in (("rosbag2_spec_mcap", make_mcap), ("rosbag2_spec_sqlite3", make_sqlite)):
        bag = BAGS / name
        if bag.exists():
            print(f"{bag} exists; delete it to rebuild", file=sys.stderr)
            continue
        make(bag, msgs)
        print(f"wrote {bag}")


if __name__ == "__main__":
    main()
