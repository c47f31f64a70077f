"""Reindex and repair bags whose recorder died (`ros2 bag reindex BAG`). ROS-free.

What it recovers
  * MCAP: every record that reached the disk, scanned from the start of the file: schemas, channels and
    messages in complete chunks, and the complete messages of a chunk that was cut while being written
    (uncompressed chunks, as our recorder writes them; zstd/lz4 chunks only when whole). The file is
    rewritten with a fresh index and summary; the damaged original is kept as ``*.mcap.broken``.
  * sqlite3: every committed row (our recorder commits every flush interval; SQLite rolls back the
    half-written transaction on open).
  * metadata.yaml is rebuilt from what the storage files actually hold.
What it cannot recover
  * messages the recorder had received but not yet flushed (at most one flush interval, 0.1 s by default),
  * a message record cut in half, and anything after a corrupted (not merely truncated) byte range in
    an MCAP file: the scan stops at the first record that does not parse,
  * a file whose MCAP magic or SQLite header is destroyed.
"""
from __future__ import annotations

import sqlite3
import struct
from dataclasses import dataclass, field
from pathlib import Path

from backports import zstd
from lz4.frame import decompress as lz4_decompress
from rosbags.interfaces import Connection, ConnectionExtRosbag2, MessageDefinition, MessageDefinitionFormat
from rosbags.rosbag2.metadata import parse_qos
from rosbags.rosbag2.storage_mcap import McapReader

from .errors import BagError
from .message_types import typestore
from .metadata import build_metadata, qos_string, write_metadata
from .storage import FlushingMcapWriter, storage_files

__all__ = ["FileReport", "reindex", "scan_mcap"]

MCAP_MAGIC = b"\x89MCAP0\r\n"
OP_SCHEMA, OP_CHANNEL, OP_MESSAGE, OP_CHUNK, OP_DATA_END, OP_FOOTER = 0x03, 0x04, 0x05, 0x06, 0x0F, 0x02


@dataclass
class FileReport:
    path: str
    status: str  # "intact", "recovered" or "empty"
    messages: int
    note: str = ""


@dataclass
class _Scan:
    schemas: dict[int, tuple[str, str, str]] = field(default_factory=dict)  # id -> (name, encoding, data)
    channels: dict[int, tuple[int, str, str, dict[str, str]]] = field(default_factory=dict)
    messages: list[tuple[int, int, bytes]] = field(default_factory=list)  # (channel, log_time, data)
    reason: str = ""


class _Cut(Exception):
    """The data ends (or stops making sense) here."""


class _Buf:
    def __init__(self, data: bytes | memoryview, base: int = 0) -> None:
        self.data, self.pos, self.base = memoryview(data), 0, base

    def take(self, n: int) -> memoryview:
        if self.pos + n > len(self.data):
            raise _Cut(f"truncated at byte {self.base + self.pos}")
        out = self.data[self.pos : self.pos + n]
        self.pos += n
        return out

    def u16(self) -> int:
        return struct.unpack("<H", self.take(2))[0]

    def u32(self) -> int:
        return struct.unpack("<I", self.take(4))[0]

    def u64(self) -> int:
        return struct.unpack("<Q", self.take(8))[0]

    def string(self) -> str:
        return bytes(self.take(self.u32())).decode("utf8")


def _parse_record(scan: _Scan, op: int, body: memoryview, base: int) -> None:
    b = _Buf(body, base)
    if op == OP_SCHEMA:
        sid = b.u16()
        name, encoding = b.string(), b.string()
        scan.schemas[sid] = (name, encoding, bytes(b.take(b.u32())).decode("utf8"))
    elif op == OP_CHANNEL:
        cid, sid = b.u16(), b.u16()
        topic, encoding = b.string(), b.string()
        meta_bytes = _Buf(b.take(b.u32()), base)
        meta: dict[str, str] = {}
        while meta_bytes.pos < len(meta_bytes.data):
            key = meta_bytes.string()
            meta[key] = meta_bytes.string()
        scan.channels[cid] = (sid, topic, encoding, meta)
    elif op == OP_MESSAGE:
        cid, _seq, log_time, _pub = b.u16(), b.u32(), b.u64(), b.u64()
        if cid not in scan.channels:
            raise _Cut(f"message on unknown channel {cid} at byte {base}")
        scan.messages.append((cid, log_time, bytes(body[b.pos :])))
    elif op == OP_CHUNK:
        _start, _end, _size, _crc = b.u64(), b.u64(), b.u64(), b.u32()
        compression = b.string()
        records = b.take(b.u64())
        _scan_records(scan, _decompress(compression, records), base + b.pos, inner=True)


def _decompress(compression: str, data: memoryview) -> memoryview:
    if compression == "":
        return data
    if compression == "zstd":
        return memoryview(zstd.decompress(bytes(data)))
    if compression == "lz4":
        return memoryview(lz4_decompress(bytes(data)))
    raise _Cut(f"unknown chunk compression {compression!r}")


def _scan_records(scan: _Scan, data: memoryview, base: int, inner: bool = False) -> None:
    """Parse records one by one; a cut inside an uncompressed chunk still yields its whole messages."""
    b = _Buf(data, base)
    while b.pos < len(data):
        start = b.pos
        op = b.take(1)[0]
        length = b.u64()
        if not inner and op in (OP_DATA_END, OP_FOOTER):
            return
        if b.pos + length > len(data):
            if op == OP_CHUNK and not inner:
                # The recorder died while writing this chunk: take its complete messages.
                partial = _Buf(data[b.pos :], base + b.pos)
                try:
                    partial.u64(), partial.u64(), partial.u64(), partial.u32()
                    if partial.string() == "":
                        partial.u64()
                        _scan_records(scan, partial.data[partial.pos :], base + b.pos + partial.pos, inner=True)
                except _Cut:
                    pass
            raise _Cut(f"record cut at byte {base + start}")
        _parse_record(scan, op, data[b.pos : b.pos + length], base + b.pos)
        b.pos += length


def scan_mcap(path: Path) -> _Scan:
    data = path.read_bytes()
    if not data.startswith(MCAP_MAGIC):
        raise BagError(f"{path} is not an MCAP file (bad magic); nothing can be recovered from it")
    scan = _Scan()
    try:
        _scan_records(scan, memoryview(data)[len(MCAP_MAGIC) :], len(MCAP_MAGIC))
    except (_Cut, UnicodeDecodeError, struct.error) as exc:
        scan.reason = str(exc)
    return scan


def _mcap_is_intact(path: Path) -> bool:
    try:
        reader = McapReader(path)
        reader.open()
        reader.close()
        return True
    except Exception:
        return False


def _rewrite_mcap(path: Path, scan: _Scan) -> tuple[list[tuple[str, str, str, list, int]], dict]:
    """Write the recovered records into a fresh MCAP at `path`; returns topic rows and file stats."""
    tmp = path.with_name(path.name + ".reindex.tmp")
    if tmp.exists():
        tmp.unlink()
    writer = FlushingMcapWriter(tmp, interval=1e9, chunk_bytes=1 << 20)
    conns: dict[int, Connection] = {}
    added_types: set[str] = set()
    counts: dict[int, int] = {}
    for cid, (sid, topic, encoding, meta) in sorted(scan.channels.items()):
        name, sencoding, sdata = scan.schemas.get(sid, ("", "", ""))
        if not name:
            continue
        fmt = MessageDefinitionFormat.IDL if sencoding == "ros2idl" else MessageDefinitionFormat.MSG
        qos = parse_qos(meta.get("offered_qos_profiles", "") or [])
        try:
            rihs01 = typestore().hash_rihs01(name)
        except Exception:
            rihs01 = ""
        conn = Connection(
            len(conns) + 1, topic, name, MessageDefinition(fmt, sdata), rihs01, 0,
            ConnectionExtRosbag2(encoding, qos), None,
        )
        if name not in added_types:
            writer.add_msgtype(conn)
            added_types.add(name)
        writer.add_connection(conn, qos_string(qos))
        conns[cid] = conn
        counts[cid] = 0
    start, end, n = 2**63 - 1, 0, 0
    for cid, stamp, data in sorted(scan.messages, key=lambda m: m[1]):
        conn = conns.get(cid)
        if conn is None:
            continue
        writer.write(conn, stamp, data)
        counts[cid] += 1
        start, end, n = min(start, stamp), max(end, stamp), n + 1
    writer.close(9, "")
    path.rename(path.with_name(path.name + ".broken"))
    tmp.rename(path)
    rows = [
        (c.topic, c.msgtype, c.digest, list(c.ext.offered_qos_profiles), counts[cid]) for cid, c in conns.items()
    ]
    return rows, {"path": path.name, "start": start, "end": end, "count": n}


def _mcap_rows(path: Path) -> tuple[list, dict]:
    reader = McapReader(path)
    reader.open()
    try:
        counts: dict[int, int] = {c.id: 0 for c in reader.connections}
        start, end, n = 2**63 - 1, 0, 0
        for conn, stamp, _ in reader.messages(reader.connections):
            counts[conn.id] += 1
            start, end, n = min(start, stamp), max(end, stamp), n + 1
        rows = []
        for c in reader.connections:
            try:
                digest = c.digest or typestore().hash_rihs01(c.msgtype)
            except Exception:
                digest = ""
            rows.append((c.topic, c.msgtype, digest, list(c.ext.offered_qos_profiles), counts[c.id]))
        return rows, {"path": path.name, "start": start, "end": end, "count": n}
    finally:
        reader.close()


def _sqlite_rows(path: Path) -> tuple[list, dict, str]:
    try:
        db = sqlite3.connect(f"file:{path}", uri=True)
        check = db.execute("PRAGMA quick_check").fetchone()[0]
        topics = db.execute("SELECT id, name, type, offered_qos_profiles, type_description_hash FROM topics").fetchall()
        stats = dict(
            ((tid, (n, lo, hi)) for tid, n, lo, hi in db.execute(
                "SELECT topic_id, COUNT(*), MIN(timestamp), MAX(timestamp) FROM messages GROUP BY topic_id"
            ))
        )
        db.close()
    except sqlite3.DatabaseError as exc:
        raise BagError(f"{path} is not a readable rosbag2 sqlite3 file ({exc})") from None
    rows, start, end, total = [], 2**63 - 1, 0, 0
    for tid, name, msgtype, qos_text, digest in topics:
        n, lo, hi = stats.get(tid, (0, None, None))
        rows.append((name, msgtype, digest or "", parse_qos(qos_text or []), n))
        if n:
            start, end, total = min(start, lo), max(end, hi), total + n
    return rows, {"path": path.name, "start": start, "end": end, "count": total}, check


def reindex(bag: str | Path) -> list[FileReport]:
    """Rebuild metadata.yaml from the bag's storage files, repairing MCAP files cut by a crash."""
    bag = Path(bag)
    if not bag.is_dir():
        raise BagError(f"{bag}: no such bag directory")
    files = storage_files(bag)
    mcaps = [p for p in files if p.suffix == ".mcap"]
    dbs = [p for p in files if p.suffix == ".db3"]
    if mcaps and dbs:
        raise BagError(f"{bag} holds both .mcap and .db3 files; a bag has one storage kind")
    if not mcaps and not dbs:
        raise BagError(f"{bag} holds no .mcap or .db3 file: nothing to reindex")
    by_topic: dict[str, list] = {}
    files, reports = [], []
    for path in mcaps or dbs:
        if path.suffix == ".mcap":
            if _mcap_is_intact(path):
                rows, info = _mcap_rows(path)
                reports.append(FileReport(path.name, "intact", info["count"]))
            else:
                scan = scan_mcap(path)
                rows, info = _rewrite_mcap(path, scan)
                note = f"cut: {scan.reason}; original kept as {path.name}.broken" if scan.reason else ""
                reports.append(FileReport(path.name, "recovered", info["count"], note))
        else:
            rows, info, check = _sqlite_rows(path)
            note = "" if check == "ok" else f"sqlite quick_check: {check}"
            reports.append(FileReport(path.name, "intact" if not note else "damaged", info["count"], note))
        files.append(info)
        for topic, msgtype, digest, qos, n in rows:
            row = by_topic.setdefault(topic, [topic, msgtype, digest, qos, 0])
            row[4] += n
    storage = "mcap" if mcaps else "sqlite3"
    write_metadata(bag, build_metadata(storage, files, [tuple(r) for r in by_topic.values()]))
    return reports

