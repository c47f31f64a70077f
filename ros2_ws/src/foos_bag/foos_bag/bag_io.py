"""Bag in, numpy out (and back): the project's ROS-free rosbag2 interface.

Everything here works without ROS running and without rclpy; it builds on `rosbags`. A bag is a
rosbag2 directory (``metadata.yaml`` plus one or more ``.mcap`` or ``.db3`` files), exactly what real
``ros2 bag record`` writes, so the files open in real ``ros2 bag``, Foxglove and the mcap CLI.

Writing::

    with BagWriter("run1") as bag:                       # refuses an existing path
        write_ball_detections(bag, t, xyz, latency=0.02)   # header stamp = t, receive time = t + latency

Reading::

    det = read_ball_detections("run1")     # BallDetections(t, position, frame_id), sorted by t
    js = read_joint_states("run1")         # JointStates(t, names, position, velocity, effort)

Every failure is a `BagError` whose message is one line that says what to do.
"""
from __future__ import annotations

import sqlite3
import time
from collections import defaultdict
from collections.abc import Iterable, Iterator, Sequence
from importlib.metadata import version as _version
from io import BytesIO, StringIO
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np
from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag2,
    MessageDefinition,
    MessageDefinitionFormat,
    Qos,
)
from rosbags.rosbag2 import Reader, ReaderError
from rosbags.rosbag2.metadata import dump_qos_v9
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk, write_record, write_string
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer
from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from ruamel.yaml import YAML

__all__ = [
    "BagError",
    "BagWriter",
    "BallDetections",
    "BallStates",
    "Commands",
    "JointStates",
    "STORAGE_SUFFIX",
    "messages",
    "read_ball_detections",
    "read_ball_states",
    "read_commands",
    "read_goals",
    "read_joint_states",
    "topics",
    "typestore",
    "write_ball_detections",
    "write_ball_states",
    "write_joint_states",
]

STORAGE_SUFFIX = {"mcap": ".mcap", "sqlite3": ".db3"}
METADATA_FILE = "metadata.yaml"
ROS_DISTRO = "jazzy"

BALL_DETECTION_TOPIC = "/ball/detection"
BALL_STATE_TOPIC = "/ball/state"
JOINT_STATES_TOPIC = "/joint_states"
GOAL_TOPIC = "/sim/goal"

POINT_STAMPED = "geometry_msgs/msg/PointStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT64_MULTI_ARRAY = "std_msgs/msg/Float64MultiArray"
STRING = "std_msgs/msg/String"


class BagError(Exception):
    """A bag cannot be written or read; the message is one line meant for the user."""


# --------------------------------------------------------------------------------------------
# Message types
# --------------------------------------------------------------------------------------------

_TYPESTORE = None


def typestore():
    """The Jazzy type store shared by the project (message classes, CDR, definitions, hashes)."""
    global _TYPESTORE
    if _TYPESTORE is None:
        _TYPESTORE = get_typestore(Stores.ROS2_JAZZY)
    return _TYPESTORE


def _ensure_type(msgtype: str, msgdef: str | None = None) -> None:
    """Make `msgtype` known to the type store, from a definition text or the installed .msg file."""
    store = typestore()
    if msgtype in store.types:
        return
    if msgdef is None:
        msgdef = _installed_msg_definition(msgtype)
    if msgdef is None:
        raise BagError(f"unknown message type {msgtype}: it is not a Jazzy type and no .msg file for it is installed")
    try:
        if msgdef.startswith("=" * 80):
            # A concatenated definition (as stored in bags): the first block is the type itself.
            blocks = msgdef.split("=" * 80 + "\n")
            types = get_types_from_msg(blocks[0], msgtype)
            for block in blocks[1:]:
                header, _, text = block.partition("\n")
                if header.startswith("MSG: "):
                    name = header[5:].strip()
                    if "/msg/" not in name:
                        name = name.replace("/", "/msg/", 1)
                    if name not in store.types:
                        types.update(get_types_from_msg(text, name))
        else:
            types = get_types_from_msg(msgdef, msgtype)
        store.register(types)
    except Exception as exc:  # rosbags raises several parser errors; all mean the same to a user
        raise BagError(f"cannot parse the definition of {msgtype}: {exc}") from None


def _installed_msg_definition(msgtype: str) -> str | None:
    import os

    package, _, name = msgtype.partition("/msg/")
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        candidate = Path(prefix, "share", package, "msg", name + ".msg")
        if prefix and candidate.is_file():
            return candidate.read_text()
    return None


def message_definition(msgtype: str) -> tuple[str, str]:
    """(rosbag2 message definition text, RIHS01 type hash) of a message type."""
    _ensure_type(msgtype)
    store = typestore()
    msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
    return msgdef, store.hash_rihs01(msgtype)


def _qos_string(qos: Sequence[Qos]) -> str:
    """QoS profiles as the YAML text rosbag2 (metadata version 9) stores per topic."""
    if not qos:
        return ""
    stream = StringIO()
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    yaml.dump(dump_qos_v9(list(qos)), stream)
    return stream.getvalue().strip()


# --------------------------------------------------------------------------------------------
# Storage files that survive a crash
# --------------------------------------------------------------------------------------------


class _FlushingMcap(McapWriter):
    """rosbags' MCAP writer, but chunks are closed and flushed to disk at least every `interval` s.

    rosbags keeps up to 1 MiB in memory; a recorder killed with SIGKILL would lose all of it. Small,
    flushed chunks mean a killed recording loses at most the last `interval` seconds, and the file
    written so far can be recovered record by record (see foos_bag.repair).
    """

    def __init__(self, path: Path, interval: float, chunk_bytes: int = 256 * 1024) -> None:
        # McapWriter.__init__ names the file after its directory; rosbag2 names it NAME_<index>.mcap,
        # so this repeats its few lines with the file path given.
        self.path = path
        self.bio = path.open("xb")
        self.bio.write(b"\x89MCAP\x30\r\n")
        rec = BytesIO()
        write_string(rec, "ros2")
        write_string(rec, f"rosbags-{_version('rosbags')}")
        write_record(self.bio, 0x01, rec)
        self.schemas = []
        self.channels = []
        self.chunks = []
        self.chunk = PendingChunk(2**63 - 1, 0, BytesIO(), defaultdict(list))
        self.compression = ""
        self.compressor = lambda x: x
        self.message_start_time = 2**63 - 1
        self.message_end_time = 0
        self.channel_stats = {}
        self.interval = interval
        self.chunk_bytes = chunk_bytes
        self.last_flush = time.monotonic()
        self.bytes_written = 0
        self.bio.flush()

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        super().write(connection, timestamp, data)
        self.bytes_written += len(data) + 31
        if self.chunk.bio.tell() > self.chunk_bytes or time.monotonic() - self.last_flush > self.interval:
            self.flush()

    def flush(self) -> None:
        if self.chunk.msgs:
            self.close_chunk()
        self.bio.flush()
        self.last_flush = time.monotonic()


class _CommittingSqlite(Sqlite3Writer):
    """rosbags' sqlite3 writer, but committed at least every `interval` s (rosbags commits only on close)."""

    def __init__(self, path: Path, interval: float) -> None:
        self.path = path
        self.conn = sqlite3.connect(f"file:{path}?mode=rwc", uri=True)
        self.conn.executescript(self.SQLITE_SCHEMA.replace("'rosbags'", f"'{ROS_DISTRO}'"))
        self.cursor = self.conn.cursor()
        self.conn.commit()
        self.interval = interval
        self.last_flush = time.monotonic()
        self.bytes_written = 0

    def write(self, connection: Connection, timestamp: int, data: bytes | memoryview) -> None:
        super().write(connection, timestamp, data)
        self.bytes_written += len(data) + 24
        if time.monotonic() - self.last_flush > self.interval:
            self.flush()

    def flush(self) -> None:
        self.conn.commit()
        self.last_flush = time.monotonic()


def _open_storage(storage: str, path: Path, interval: float):
    if path.exists():
        raise BagError(f"{path} exists already; refusing to overwrite it")
    if storage == "mcap":
        return _FlushingMcap(path, interval)
    return _CommittingSqlite(path, interval)


# --------------------------------------------------------------------------------------------
# Writer
# --------------------------------------------------------------------------------------------


class _Topic(NamedTuple):
    topic: str
    msgtype: str
    msgdef: str
    rihs01: str
    qos: tuple[Qos, ...]


class BagWriter:
    """Writes a rosbag2 directory (MCAP or sqlite3), split by size or duration if asked.

    Files are named as real rosbag2 names them (``NAME_0.mcap``, ``NAME_1.mcap``...). Data reaches the
    disk at least every `flush_interval` seconds, so a killed writer leaves a repairable bag; the
    ``metadata.yaml`` is written on every split and on close.
    """

    def __init__(
        self,
        path: str | Path,
        storage: str = "mcap",
        *,
        max_bag_size: int = 0,
        max_bag_duration: float = 0.0,
        flush_interval: float = 0.1,
        custom_data: dict[str, str] | None = None,
    ) -> None:
        self.path = Path(path)
        if storage not in STORAGE_SUFFIX:
            raise BagError(f"unknown storage {storage!r}: use one of {', '.join(STORAGE_SUFFIX)}")
        self.check_new_path(self.path)
        if max_bag_size < 0 or max_bag_duration < 0:
            raise BagError("split limits must be positive (0 = no split)")
        self.storage_id = storage
        self.max_bag_size = int(max_bag_size)
        self.max_bag_duration_ns = int(max_bag_duration * 1e9)
        self.flush_interval = flush_interval
        self.custom_data = dict(custom_data or {})
        try:
            self.path.mkdir(mode=0o755)
        except OSError as exc:
            raise BagError(f"cannot create {self.path}: {exc.strerror}") from None
        self._topics: dict[str, _Topic] = {}
        self._counts: dict[str, int] = {}
        self._files: list[dict[str, Any]] = []  # per closed file: path, start, end, count
        self._storage = None
        self._conns: dict[str, Connection] = {}
        self._file_start = 2**63 - 1
        self._file_end = 0
        self._file_count = 0
        self._closed = False
        self._open_next_file()

    @staticmethod
    def check_new_path(path: str | Path) -> None:
        """BagError unless a bag can be created at `path` (it must not exist; its parent must)."""
        path = Path(path)
        if path.exists():
            raise BagError(f"{path} exists already; refusing to overwrite it (choose another name or delete it)")
        if not path.parent.exists():
            raise BagError(f"cannot create {path}: its parent directory {path.parent} does not exist")

    # -- context manager ------------------------------------------------------------------
    def __enter__(self) -> BagWriter:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # -- topics -----------------------------------------------------------------------------
    def add_topic(
        self,
        topic: str,
        msgtype: str,
        *,
        qos: Sequence[Qos] = (),
        msgdef: str | None = None,
        rihs01: str | None = None,
    ) -> None:
        """Declare a topic before writing to it; declaring the same topic and type again is a no-op."""
        self._check_open()
        if not topic.startswith("/"):
            raise BagError(f"topic {topic!r} must be an absolute name starting with '/'")
        if "/msg/" not in msgtype:
            raise BagError(f"message type {msgtype!r} must look like 'package/msg/Name'")
        known = self._topics.get(topic)
        if known is not None:
            if known.msgtype != msgtype:
                raise BagError(f"topic {topic} is already recorded as {known.msgtype}, not {msgtype}")
            return
        if msgdef is None or rihs01 is None:
            msgdef, rihs01 = message_definition(msgtype)
        else:
            _ensure_type(msgtype, msgdef)
        info = _Topic(topic, msgtype, msgdef, rihs01, tuple(qos))
        self._topics[topic] = info
        self._counts[topic] = 0
        self._add_connection(info)

    def has_topic(self, topic: str) -> bool:
        return topic in self._topics

    def _add_connection(self, info: _Topic) -> None:
        fmt = MessageDefinitionFormat.IDL if info.msgdef.startswith("=" * 80 + "\nIDL: ") else MessageDefinitionFormat.MSG
        conn = Connection(
            id=len(self._conns) + 1,
            topic=info.topic,
            msgtype=info.msgtype,
            msgdef=MessageDefinition(fmt, info.msgdef),
            digest=info.rihs01,
            msgcount=0,
            ext=ConnectionExtRosbag2(serialization_format="cdr", offered_qos_profiles=list(info.qos)),
            owner=self,
        )
        if info.msgtype not in {c.msgtype for c in self._conns.values()}:
            self._storage.add_msgtype(conn)
        self._storage.add_connection(conn, _qos_string(info.qos))
        self._conns[info.topic] = conn

    # -- writing ---------------------------------------------------------------------------
    def write_raw(self, topic: str, timestamp_ns: int, cdr: bytes | memoryview) -> None:
        """Store CDR bytes as they are, received at `timestamp_ns` (ns since the epoch, or sim time)."""
        conn = self._conns.get(topic)
        if conn is None:
            self._check_open()
            raise BagError(f"topic {topic} was not added to the bag before writing (call add_topic first)")
        timestamp_ns = int(timestamp_ns)
        if timestamp_ns < 0:
            raise BagError(f"negative timestamp {timestamp_ns} ns on {topic}")
        if self._needs_split(timestamp_ns):
            self._split()
            conn = self._conns[topic]
        self._storage.write(conn, timestamp_ns, cdr)
        self._counts[topic] += 1
        self._file_count += 1
        if timestamp_ns < self._file_start:
            self._file_start = timestamp_ns
        if timestamp_ns > self._file_end:
            self._file_end = timestamp_ns

    def write(self, topic: str, timestamp_ns: int, msg: object) -> None:
        """Serialize a rosbags message object (see `typestore().types`) and store it."""
        info = self._topics.get(topic)
        if info is None:
            self._check_open()
            raise BagError(f"topic {topic} was not added to the bag before writing (call add_topic first)")
        try:
            cdr = typestore().serialize_cdr(msg, info.msgtype)
        except Exception as exc:
            raise BagError(f"cannot serialize a message for {topic} as {info.msgtype}: {exc}") from None
        self.write_raw(topic, timestamp_ns, cdr)

    def flush(self) -> None:
        """Push everything written so far to disk (the recorder calls this on a timer)."""
        if self._storage is not None:
            self._storage.flush()

    @property
    def message_counts(self) -> dict[str, int]:
        return dict(self._counts)

    # -- splitting ---------------------------------------------------------------------------
    def _needs_split(self, timestamp_ns: int) -> bool:
        if self._file_count == 0:
            return False
        if self.max_bag_size and self._storage.bytes_written >= self.max_bag_size:
            return True
        return bool(self.max_bag_duration_ns and timestamp_ns - self._file_start >= self.max_bag_duration_ns)

    def _split(self) -> None:
        self._close_file()
        self._write_metadata()  # a finished file is listed at once, as rosbag2 does on split
        self._open_next_file()
        for info in self._topics.values():
            self._add_connection(info)

    def _open_next_file(self) -> None:
        name = f"{self.path.name}_{len(self._files)}{STORAGE_SUFFIX[self.storage_id]}"
        try:
            self._storage = _open_storage(self.storage_id, self.path / name, self.flush_interval)
        except OSError as exc:
            raise BagError(f"cannot create {self.path / name}: {exc}") from None
        self._conns = {}
        self._file_start, self._file_end, self._file_count = 2**63 - 1, 0, 0
        self._current_name = name

    def _close_file(self) -> None:
        storage, self._storage = self._storage, None
        storage.close(9, self._metadata_text(single_file=True))
        self._files.append(
            {"path": self._current_name, "start": self._file_start, "end": self._file_end, "count": self._file_count}
        )

    # -- metadata ----------------------------------------------------------------------------
    def _metadata(self, files: list[dict[str, Any]]) -> dict[str, Any]:
        return build_metadata(
            self.storage_id,
            files,
            [(t.topic, t.msgtype, t.rihs01, t.qos, self._counts[t.topic]) for t in self._topics.values()],
            self.custom_data,
        )

    def _metadata_text(self, single_file: bool) -> str:
        files = [{"path": self._current_name, "start": self._file_start, "end": self._file_end, "count": self._file_count}]
        stream = StringIO()
        yaml = YAML(typ="safe")
        yaml.default_flow_style = False
        yaml.dump(self._metadata(files if single_file else self._files)["rosbag2_bagfile_information"], stream)
        return stream.getvalue().strip()

    def _write_metadata(self) -> None:
        write_metadata(self.path, self._metadata(self._files))

    # -- closing -------------------------------------------------------------------------------
    def close(self) -> None:
        """Finish the last file and write metadata.yaml; safe to call twice."""
        if self._closed:
            return
        self._closed = True
        self._close_file()
        self._write_metadata()

    def _check_open(self) -> None:
        if self._closed:
            raise BagError(f"bag {self.path} is already closed")


def build_metadata(
    storage_id: str,
    files: list[dict[str, Any]],
    topic_rows: Iterable[tuple[str, str, str, Sequence[Qos], int]],
    custom_data: dict[str, str] | None = None,
) -> dict[str, Any]:
    """The metadata.yaml content (rosbag2 version 9) for files [{path, start, end, count}] and topics."""
    nonempty = [f for f in files if f["count"]]
    start = min((f["start"] for f in nonempty), default=0)
    end = max((f["end"] for f in nonempty), default=0)
    count = sum(f["count"] for f in files)
    return {
        "rosbag2_bagfile_information": {
            "version": 9,
            "storage_identifier": storage_id,
            "duration": {"nanoseconds": max(0, end - start)},
            "starting_time": {"nanoseconds_since_epoch": start},
            "message_count": count,
            "topics_with_message_count": [
                {
                    "topic_metadata": {
                        "name": topic,
                        "type": msgtype,
                        "serialization_format": "cdr",
                        "offered_qos_profiles": dump_qos_v9(list(qos)),
                        "type_description_hash": rihs01,
                    },
                    "message_count": n,
                }
                for topic, msgtype, rihs01, qos, n in topic_rows
            ],
            "compression_format": "",
            "compression_mode": "",
            "relative_file_paths": [f["path"] for f in files],
            "files": [
                {
                    "path": f["path"],
                    "starting_time": {"nanoseconds_since_epoch": f["start"] if f["count"] else 0},
                    "duration": {"nanoseconds": max(0, f["end"] - f["start"]) if f["count"] else 0},
                    "message_count": f["count"],
                }
                for f in files
            ],
            "custom_data": custom_data or None,
            "ros_distro": ROS_DISTRO,
        }
    }


def write_metadata(bag: Path, metadata: dict[str, Any]) -> None:
    """Write metadata.yaml atomically (a crash leaves the old one or the new one, never half)."""
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    stream = StringIO()
    yaml.dump(metadata, stream)
    tmp = bag / (METADATA_FILE + ".tmp")
    tmp.write_text(stream.getvalue(), "utf8")
    tmp.replace(bag / METADATA_FILE)


# --------------------------------------------------------------------------------------------
# Array writers (offline producers: sim, video tracker)
# --------------------------------------------------------------------------------------------


def _as_times(t: Any, what: str) -> np.ndarray:
    t = np.asarray(t, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(t)):
        raise BagError(f"{what}: times contain NaN or infinity")
    if np.any(t < 0):
        raise BagError(f"{what}: times must be >= 0 s (a bag stores unsigned nanoseconds)")
    return t


def _as_rows(a: Any, n: int, width: int | None, what: str) -> np.ndarray:
    a = np.asarray(a, dtype=np.float64)
    if a.ndim == 1 and width is None:
        a = a.reshape(n, -1) if n else a.reshape(0, 0)
    if a.ndim != 2 or a.shape[0] != n or (width is not None and a.shape[1] != width):
        want = f"({n}, {width})" if width is not None else f"({n}, J)"
        raise BagError(f"{what}: expected an array of shape {want}, got {a.shape}")
    return a


def _ns(seconds: float) -> int:
    return int(round(seconds * 1e9))


def _stamp(seconds: float):
    ns = _ns(seconds)
    return typestore().types["builtin_interfaces/msg/Time"](sec=ns // 1_000_000_000, nanosec=ns % 1_000_000_000)


def _header(seconds: float, frame_id: str):
    return typestore().types["std_msgs/msg/Header"](stamp=_stamp(seconds), frame_id=frame_id)


def _write_sorted(writer: BagWriter, topic: str, receive: np.ndarray, cdrs: list) -> None:
    for i in np.argsort(receive, kind="stable"):
        writer.write_raw(topic, _ns(receive[i]), cdrs[i])


def write_ball_detections(
    writer: BagWriter,
    t: Any,
    position: Any,
    frame_id: str = "table",
    topic: str = BALL_DETECTION_TOPIC,
    latency: Any = 0.0,
) -> None:
    """Ball detections as geometry_msgs/PointStamped: header stamp = t (capture), receive time = t + latency.

    `latency` is a number or an array like `t` (per-detection latency, s, >= 0).
    """
    t = _as_times(t, topic)
    position = _as_rows(position, len(t), 3, f"{topic} position")
    if not np.all(np.isfinite(position)):
        raise BagError(f"{topic}: positions contain NaN or infinity (drop missed detections instead)")
    latency = np.broadcast_to(np.asarray(latency, dtype=np.float64), t.shape)
    if not np.all(np.isfinite(latency)) or np.any(latency < 0):
        raise BagError(f"{topic}: latency must be finite and >= 0 s")
    writer.add_topic(topic, POINT_STAMPED)
    store = typestore()
    point_stamped, point = store.types[POINT_STAMPED], store.types["geometry_msgs/msg/Point"]
    cdrs = [
        store.serialize_cdr(point_stamped(header=_header(ti, frame_id), point=point(x=p[0], y=p[1], z=p[2])), POINT_STAMPED)
        for ti, p in zip(t.tolist(), position.tolist())
    ]
    _write_sorted(writer, topic, t + latency, cdrs)


def write_ball_states(writer: BagWriter, t: Any, position: Any, velocity: Any, topic: str = BALL_STATE_TOPIC) -> None:
    """Ball states as nav_msgs/Odometry (frame `table`, child `ball`), received at their stamp."""
    t = _as_times(t, topic)
    position = _as_rows(position, len(t), 3, f"{topic} position")
    velocity = _as_rows(velocity, len(t), 3, f"{topic} velocity")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        raise BagError(f"{topic}: positions or velocities contain NaN or infinity")
    writer.add_topic(topic, ODOMETRY)
    store = typestore()
    T = store.types
    cov = np.zeros(36)
    cdrs = []
    for ti, p, v in zip(t.tolist(), position.tolist(), velocity.tolist()):
        msg = T[ODOMETRY](
            header=_header(ti, "table"),
            child_frame_id="ball",
            pose=T["geometry_msgs/msg/PoseWithCovariance"](
                pose=T["geometry_msgs/msg/Pose"](
                    position=T["geometry_msgs/msg/Point"](x=p[0], y=p[1], z=p[2]),
                    orientation=T["geometry_msgs/msg/Quaternion"](x=0.0, y=0.0, z=0.0, w=1.0),
                ),
                covariance=cov,
            ),
            twist=T["geometry_msgs/msg/TwistWithCovariance"](
                twist=T["geometry_msgs/msg/Twist"](
                    linear=T["geometry_msgs/msg/Vector3"](x=v[0], y=v[1], z=v[2]),
                    angular=T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.0),
                ),
                covariance=cov,
            ),
        )
        cdrs.append(store.serialize_cdr(msg, ODOMETRY))
    _write_sorted(writer, topic, t, cdrs)


def write_joint_states(
    writer: BagWriter, t: Any, names: Sequence[str], position: Any, velocity: Any, topic: str = JOINT_STATES_TOPIC
) -> None:
    """Joint states as sensor_msgs/JointState (no effort), received at their stamp."""
    t = _as_times(t, topic)
    names = [str(n) for n in names]
    position = _as_rows(position, len(t), len(names), f"{topic} position")
    velocity = _as_rows(velocity, len(t), len(names), f"{topic} velocity")
    if not (np.all(np.isfinite(position)) and np.all(np.isfinite(velocity))):
        raise BagError(f"{topic}: positions or velocities contain NaN or infinity")
    writer.add_topic(topic, JOINT_STATE)
    store = typestore()
    empty = np.zeros(0)
    cdrs = [
        store.serialize_cdr(
            store.types[JOINT_STATE](header=_header(ti, ""), name=names, position=p, velocity=v, effort=empty),
            JOINT_STATE,
        )
        for ti, p, v in zip(t.tolist(), position, velocity)
    ]
    _write_sorted(writer, topic, t, cdrs)


# --------------------------------------------------------------------------------------------
# Readers
# --------------------------------------------------------------------------------------------


class BallDetections(NamedTuple):
    t: np.ndarray  # (N,) capture stamps, s, sorted
    position: np.ndarray  # (N, 3) m, in frame_id
    frame_id: str


class BallStates(NamedTuple):
    t: np.ndarray  # (N,) header stamps, s, sorted
    position: np.ndarray  # (N, 3) m
    velocity: np.ndarray  # (N, 3) m/s


class JointStates(NamedTuple):
    t: np.ndarray  # (N,) header stamps, s, sorted
    names: list[str]  # J joint names, the column order of the arrays
    position: np.ndarray  # (N, J)
    velocity: np.ndarray  # (N, J), NaN where not published
    effort: np.ndarray  # (N, J), NaN where not published


class Commands(NamedTuple):
    t: np.ndarray  # (N,) receive times, s (Float64MultiArray has no header)
    values: np.ndarray  # (N, 8)


def open_reader(path: str | Path) -> Reader:
    """An opened rosbags Reader for a bag directory (or a single .mcap/.db3 file), or a clear BagError."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"{path}: no such bag (file or directory not found)")
    if path.is_dir() and not (path / METADATA_FILE).exists():
        storage = sorted(p.name for p in path.iterdir() if p.suffix in (".mcap", ".db3"))
        if storage:
            raise BagError(
                f"{path} has no metadata.yaml: its recorder did not finish (killed?); "
                f"run `ros2 bag reindex {path}` to recover it"
            )
        raise BagError(f"{path} is not a bag: no metadata.yaml and no .mcap or .db3 file in it")
    if path.is_dir():
        _check_all_files_listed(path)
    if path.is_file() and path.suffix not in (".mcap", ".db3"):
        raise BagError(f"{path} is not a bag: expected a rosbag2 directory, a .mcap or a .db3 file")
    try:
        reader = Reader(path)
        reader.open()
    except (ReaderError, OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise BagError(
            f"{path} is corrupt or truncated ({reason}); `ros2 bag reindex {path}` may recover it"
        ) from None
    except Exception as exc:  # sqlite3/apsw and struct errors from damaged files
        reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise BagError(f"{path} is corrupt or truncated ({reason})") from None
    return reader


def _check_all_files_listed(bag: Path) -> None:
    """A split recording killed mid-file leaves metadata.yaml listing only the finished files: say so
    rather than silently reading less."""
    try:
        info = YAML(typ="safe").load((bag / METADATA_FILE).read_text())["rosbag2_bagfile_information"]
        listed = {Path(p).name for p in info.get("relative_file_paths", [])}
    except Exception:
        return  # the reader reports unreadable metadata with its own message
    unlisted = sorted(
        p.name for p in bag.iterdir() if p.suffix in (".mcap", ".db3") and p.name not in listed
    )
    if unlisted:
        raise BagError(
            f"{bag} holds {', '.join(unlisted)} that metadata.yaml does not list (its recorder was killed?); "
            f"run `ros2 bag reindex {bag}` to include them"
        )


def storage_files(bag: str | Path) -> list[Path]:
    """The .mcap/.db3 files of a bag directory in split order (NAME_0, NAME_1, ... NAME_10)."""
    import re

    def key(p: Path) -> tuple[int, str]:
        m = re.search(r"_(\d+)\.(mcap|db3)$", p.name)
        return (int(m.group(1)) if m else 0, p.name)

    return sorted((p for p in Path(bag).iterdir() if p.suffix in (".mcap", ".db3")), key=key)


def topics(path: str | Path) -> dict[str, tuple[str, int]]:
    """{topic: (msgtype, message count)} of a bag."""
    reader = open_reader(path)
    try:
        return {name: (info.msgtype or "", info.msgcount) for name, info in reader.topics.items()}
    finally:
        reader.close()


def messages(
    path: str | Path, topic_names: Iterable[str] | None = None, *, raw: bool = False
) -> Iterator[tuple[str, int, Any]]:
    """(topic, receive time ns, message) in receive-time order; `raw=True` gives the CDR bytes instead.

    Asking for a topic the bag does not have is a BagError.
    """
    reader = open_reader(path)
    try:
        wanted = None if topic_names is None else list(topic_names)
        conns = reader.connections
        if wanted is not None:
            have = {c.topic for c in conns}
            missing = [t for t in wanted if t not in have]
            if missing:
                raise BagError(
                    f"{path} has no topic {', '.join(missing)} (it has: {', '.join(sorted(have)) or 'no topics'})"
                )
            conns = [c for c in conns if c.topic in wanted]
        for conn in conns:
            if not raw:
                _ensure_type(conn.msgtype, conn.msgdef.data or None)
        try:
            for conn, timestamp, data in reader.messages(connections=conns):
                if raw:
                    yield conn.topic, timestamp, data
                else:
                    yield conn.topic, timestamp, deserialize(data, conn.msgtype)
        except BagError:
            raise
        except Exception as exc:
            reason = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
            raise BagError(f"{path} is corrupt or truncated while reading messages ({reason})") from None
    finally:
        reader.close()


def deserialize(cdr: bytes | memoryview, msgtype: str) -> Any:
    """CDR bytes -> rosbags message object.

    Unlike rosbags' own check, trailing bytes are accepted: Fast DDS (and so real rosbag2 recordings)
    pads serialized messages past their end, e.g. a JointState with an empty effort carries 4 extra bytes.
    """
    if len(cdr) < 4 or bytes(cdr[:2]) not in (b"\x00\x00", b"\x00\x01"):
        raise ValueError(f"not a CDR {msgtype} message (bad encapsulation header)")
    msgdef = typestore().get_msgdef(msgtype)
    func = msgdef.deserialize_cdr_le if cdr[1] else msgdef.deserialize_cdr_be
    message, _ = func(memoryview(cdr)[4:], 0, msgdef.cls, typestore())
    return message


def _stamp_s(header) -> float:
    return header.stamp.sec + header.stamp.nanosec * 1e-9


def _need(n: int, path: str | Path, topic: str) -> None:
    if n == 0:
        raise BagError(f"{path}: topic {topic} has no messages")


def read_ball_detections(path: str | Path, topic: str = BALL_DETECTION_TOPIC) -> BallDetections:
    """Ball detections: header (capture) stamps in s sorted, positions (N,3) and the frame."""
    t, p, frames = [], [], set()
    for _, _, msg in messages(path, [topic]):
        t.append(_stamp_s(msg.header))
        p.append((msg.point.x, msg.point.y, msg.point.z))
        frames.add(msg.header.frame_id)
    _need(len(t), path, topic)
    if len(frames) > 1:
        raise BagError(f"{path}: {topic} mixes frames {sorted(frames)}; expected one")
    order = np.argsort(np.asarray(t), kind="stable")
    return BallDetections(np.asarray(t)[order], np.asarray(p, dtype=np.float64)[order], frames.pop())


def read_ball_states(path: str | Path, topic: str = BALL_STATE_TOPIC) -> BallStates:
    """Ball states from nav_msgs/Odometry: stamps in s sorted, positions and linear velocities (N,3)."""
    t, p, v = [], [], []
    for _, _, msg in messages(path, [topic]):
        t.append(_stamp_s(msg.header))
        q, w = msg.pose.pose.position, msg.twist.twist.linear
        p.append((q.x, q.y, q.z))
        v.append((w.x, w.y, w.z))
    _need(len(t), path, topic)
    order = np.argsort(np.asarray(t), kind="stable")
    return BallStates(np.asarray(t)[order], np.asarray(p, dtype=np.float64)[order], np.asarray(v, dtype=np.float64)[order])


def read_joint_states(path: str | Path, topic: str = JOINT_STATES_TOPIC) -> JointStates:
    """Joint states as (N, J) arrays, columns in the order of the first message's names.

    Messages that list the joints in another order are reordered by name; a joint missing from a message,
    or a message without velocity/effort, gives NaN there.
    """
    t: list[float] = []
    rows_p, rows_v, rows_e = [], [], []
    names: list[str] | None = None
    column: dict[str, int] = {}
    for _, _, msg in messages(path, [topic]):
        if names is None:
            names = list(msg.name)
            column = {n: i for i, n in enumerate(names)}
        J = len(names)
        p, v, e = np.full(J, np.nan), np.full(J, np.nan), np.full(J, np.nan)
        for k, name in enumerate(msg.name):
            i = column.get(name)
            if i is None:
                continue
            if k < len(msg.position):
                p[i] = msg.position[k]
            if k < len(msg.velocity):
                v[i] = msg.velocity[k]
            if k < len(msg.effort):
                e[i] = msg.effort[k]
        t.append(_stamp_s(msg.header))
        rows_p.append(p)
        rows_v.append(v)
        rows_e.append(e)
    _need(len(t), path, topic)
    order = np.argsort(np.asarray(t), kind="stable")
    return JointStates(
        np.asarray(t)[order],
        names or [],
        np.asarray(rows_p)[order],
        np.asarray(rows_v)[order],
        np.asarray(rows_e)[order],
    )


def read_commands(path: str | Path, team: str) -> Commands:
    """Rod commands of `team` ('home' or 'away'): receive times in s and the (N, 8) target velocities."""
    if team not in ("home", "away"):
        raise BagError(f"team must be 'home' or 'away', not {team!r}")
    topic = f"/{team}/rods/command"
    t, values = [], []
    for _, stamp, msg in messages(path, [topic]):
        data = np.asarray(msg.data, dtype=np.float64)
        if data.shape != (8,):
            raise BagError(f"{path}: a {topic} message holds {data.size} values, expected 8")
        t.append(stamp * 1e-9)
        values.append(data)
    _need(len(t), path, topic)
    return Commands(np.asarray(t), np.asarray(values))


def read_goals(path: str | Path, topic: str = GOAL_TOPIC) -> tuple[np.ndarray, list[str]]:
    """Goals: receive times in s and the scoring team per goal. A bag without goals gives empty arrays
    only if it has the topic; a bag without the topic is a BagError."""
    t, teams = [], []
    for _, stamp, msg in messages(path, [topic]):
        t.append(stamp * 1e-9)
        teams.append(msg.data)
    return np.asarray(t, dtype=np.float64), teams
