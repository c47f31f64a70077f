"""Opening a bag and reading its messages: rosbags' Reader behind errors that say what to do, and CDR
decoding that accepts what Fast DDS writes."""
from __future__ import annotations

from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from rosbags.rosbag2 import Reader, ReaderError
from ruamel.yaml import YAML

from .errors import BagError, first_line
from .message_types import register_type, typestore
from .metadata import METADATA_FILE
from .storage import STORAGE_SUFFIX

__all__ = ["check_topics", "damaged_file_errors", "deserialize", "messages", "open_reader", "topics"]


def _is_storage_file(path: Path) -> bool:
    return path.suffix in STORAGE_SUFFIX.values()


def open_reader(path: str | Path) -> Reader:
    """An opened rosbags Reader for a bag directory (or a single .mcap/.db3 file), or a clear BagError."""
    path = Path(path)
    if not path.exists():
        raise BagError(f"{path}: no such bag (file or directory not found)")
    if path.is_dir() and not (path / METADATA_FILE).exists():
        if any(_is_storage_file(p) for p in path.iterdir()):
            raise BagError(
                f"{path} has no metadata.yaml: its recorder did not finish (killed?); "
                f"run `ros2 bag reindex {path}` to recover it"
            )
        raise BagError(f"{path} is not a bag: no metadata.yaml and no .mcap or .db3 file in it")
    if path.is_dir():
        _check_all_files_listed(path)
    if path.is_file() and not _is_storage_file(path):
        raise BagError(f"{path} is not a bag: expected a rosbag2 directory, a .mcap or a .db3 file")
    try:
        reader = Reader(path)
        reader.open()
    except (ReaderError, OSError, ValueError, KeyError, TypeError, IndexError) as exc:
        raise BagError(
            f"{path} is corrupt or truncated ({first_line(exc)}); `ros2 bag reindex {path}` may recover it"
        ) from None
    except Exception as exc:  # sqlite3/apsw and struct errors from damaged files
        raise BagError(f"{path} is corrupt or truncated ({first_line(exc)})") from None
    return reader


def _check_all_files_listed(bag: Path) -> None:
    """A split recording killed mid-file leaves metadata.yaml listing only the finished files: say so
    rather than silently reading less."""
    try:
        info = YAML(typ="safe").load((bag / METADATA_FILE).read_text())["rosbag2_bagfile_information"]
        listed = {Path(p).name for p in info.get("relative_file_paths", [])}
    except Exception:
        return  # the reader reports unreadable metadata with its own message
    unlisted = sorted(p.name for p in bag.iterdir() if _is_storage_file(p) and p.name not in listed)
    if unlisted:
        raise BagError(
            f"{bag} holds {', '.join(unlisted)} that metadata.yaml does not list (its recorder was killed?); "
            f"run `ros2 bag reindex {bag}` to include them"
        )


def check_topics(path: str | Path, wanted: Iterable[str], have: Iterable[str]) -> None:
    """BagError naming the wanted topics the bag at `path` does not have, and those it has."""
    have = set(have)
    missing = [t for t in wanted if t not in have]
    if missing:
        raise BagError(f"{path} has no topic {', '.join(missing)} (it has: {', '.join(sorted(have)) or 'no topics'})")


@contextmanager
def damaged_file_errors(path: str | Path, activity: str) -> Iterator[None]:
    """Whatever a damaged file makes rosbags raise while `activity` (rosbags, sqlite and struct errors, a
    failed decode) as a one-line BagError; a BagError passes as it is."""
    try:
        yield
    except BagError:
        raise
    except Exception as exc:
        raise BagError(f"{path} is corrupt or truncated while {activity} ({first_line(exc)})") from None


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
        conns = reader.connections
        if topic_names is not None:
            wanted = list(topic_names)
            check_topics(path, wanted, (c.topic for c in conns))
            conns = [c for c in conns if c.topic in wanted]
        if not raw:
            for conn in conns:
                register_type(conn.msgtype, conn.msgdef.data or None)
        with damaged_file_errors(path, "reading messages"):
            for conn, timestamp, data in reader.messages(connections=conns):
                if raw:
                    yield conn.topic, timestamp, data
                else:
                    yield conn.topic, timestamp, deserialize(data, conn.msgtype)
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
