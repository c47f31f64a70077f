"""BagWriter: a rosbag2 directory (MCAP or sqlite3) written message by message, split by size or duration,
and left repairable by a crash.

    with BagWriter("run1") as bag:                 # refuses an existing path
        bag.add_topic("/sim/goal", STRING)
        bag.write("/sim/goal", receive_ns, typestore().types[STRING](data="home"))
"""
from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path
from typing import Any, NamedTuple

from rosbags.interfaces import (
    Connection,
    ConnectionExtRosbag2,
    MessageDefinition,
    MessageDefinitionFormat,
    Qos,
)

from .errors import BagError
from .message_types import DEFINITION_RULE, message_definition, register_type, typestore
from .metadata import build_metadata, qos_string, write_metadata, yaml_text
from .storage import STORAGE_SUFFIX, open_storage, storage_file_name

__all__ = ["BagWriter"]


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
            register_type(msgtype, msgdef)
        info = _Topic(topic, msgtype, msgdef, rihs01, tuple(qos))
        self._topics[topic] = info
        self._counts[topic] = 0
        self._add_connection(info)

    def has_topic(self, topic: str) -> bool:
        return topic in self._topics

    def _add_connection(self, info: _Topic) -> None:
        idl = info.msgdef.startswith(DEFINITION_RULE + "\nIDL: ")
        fmt = MessageDefinitionFormat.IDL if idl else MessageDefinitionFormat.MSG
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
        self._storage.add_connection(conn, qos_string(info.qos))
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
        name = storage_file_name(self.path, len(self._files), self.storage_id)
        try:
            self._storage = open_storage(self.storage_id, self.path / name, self.flush_interval)
        except OSError as exc:
            raise BagError(f"cannot create {self.path / name}: {exc}") from None
        self._conns = {}
        self._file_start, self._file_end, self._file_count = 2**63 - 1, 0, 0
        self._current_name = name

    def _current_file(self) -> dict[str, Any]:
        return {"path": self._current_name, "start": self._file_start, "end": self._file_end, "count": self._file_count}

    def _close_file(self) -> None:
        storage, self._storage = self._storage, None
        storage.close(9, self._file_metadata_text())
        self._files.append(self._current_file())

    # -- metadata ----------------------------------------------------------------------------
    def _metadata(self, files: list[dict[str, Any]]) -> dict[str, Any]:
        return build_metadata(
            self.storage_id,
            files,
            [(t.topic, t.msgtype, t.rihs01, t.qos, self._counts[t.topic]) for t in self._topics.values()],
            self.custom_data,
        )

    def _file_metadata_text(self) -> str:
        """The metadata of the current file alone, which rosbag2 keeps inside each storage file."""
        return yaml_text(self._metadata([self._current_file()])["rosbag2_bagfile_information"]).strip()

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
