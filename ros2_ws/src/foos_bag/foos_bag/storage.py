"""Storage files that survive a crash: rosbags' MCAP and sqlite3 writers, flushed to disk on a timer, and
the names rosbag2 gives a bag's files (NAME_0.mcap, NAME_1.mcap, ...)."""
from __future__ import annotations

import re
import sqlite3
import time
from collections import defaultdict
from importlib.metadata import version
from io import BytesIO
from pathlib import Path

from rosbags.interfaces import Connection
from rosbags.rosbag2.storage_mcap import McapWriter, PendingChunk, write_record, write_string
from rosbags.rosbag2.storage_sqlite3 import Sqlite3Writer

from .errors import BagError
from .metadata import ROS_DISTRO

__all__ = ["STORAGE_SUFFIX", "CommittingSqliteWriter", "FlushingMcapWriter", "open_storage", "storage_file_name",
           "storage_files"]

STORAGE_SUFFIX = {"mcap": ".mcap", "sqlite3": ".db3"}


class FlushingMcapWriter(McapWriter):
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
        write_string(rec, f"rosbags-{version('rosbags')}")
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


class CommittingSqliteWriter(Sqlite3Writer):
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


def open_storage(storage: str, path: Path, interval: float) -> FlushingMcapWriter | CommittingSqliteWriter:
    """A new storage file at `path` flushed every `interval` s; an existing file is a BagError."""
    if path.exists():
        raise BagError(f"{path} exists already; refusing to overwrite it")
    if storage == "mcap":
        return FlushingMcapWriter(path, interval)
    return CommittingSqliteWriter(path, interval)


def storage_file_name(bag: Path, index: int, storage: str) -> str:
    """The name of a bag's `index`-th file: NAME_<index>.mcap or .db3, as rosbag2 names it."""
    return f"{bag.name}_{index}{STORAGE_SUFFIX[storage]}"


def storage_files(bag: str | Path) -> list[Path]:
    """The .mcap/.db3 files of a bag directory in split order (NAME_0, NAME_1, ... NAME_10)."""

    def key(p: Path) -> tuple[int, str]:
        m = re.search(r"_(\d+)\.(mcap|db3)$", p.name)
        return (int(m.group(1)) if m else 0, p.name)

    return sorted((p for p in Path(bag).iterdir() if p.suffix in STORAGE_SUFFIX.values()), key=key)
