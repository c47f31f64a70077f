"""`ros2 bag info BAG`: a summary laid out like real rosbag2's. ROS-free."""
from __future__ import annotations

import time
from pathlib import Path

from .reader import open_reader
from .storage import STORAGE_SUFFIX, storage_files

__all__ = ["summary"]

STORAGE_OF_SUFFIX = {suffix: storage for storage, suffix in STORAGE_SUFFIX.items()}


def _size(n: float) -> str:
    for unit in ("B", "KiB", "MiB", "GiB"):
        if n < 1024 or unit == "GiB":
            return f"{n:.1f} {unit}" if unit != "B" else f"{int(n)} B"
        n /= 1024
    return f"{n:.1f} GiB"


def _when(ns: int) -> str:
    sec, frac = divmod(ns, 1_000_000_000)
    return f"{time.strftime('%b %d %Y %H:%M:%S', time.localtime(sec))}.{frac:09d} ({sec}.{frac:09d})"


def summary(path: str | Path) -> str:
    """The text `ros2 bag info` prints."""
    path = Path(path)
    reader = open_reader(path)
    try:
        if path.is_dir():
            files = storage_files(path)
        else:
            files = [path]
        size = sum(p.stat().st_size for p in files)
        storage = STORAGE_OF_SUFFIX.get(files[0].suffix, "?") if files else "?"
        count = reader.message_count
        start = reader.start_time if count else 0
        end = reader.end_time - 1 if count else 0  # rosbags reports one past the last message
        topics = reader.topics
        distro = reader.ros_distro or "unknown"
    finally:
        reader.close()
    pad = " " * 19
    lines = [
        f"Files:             {files[0].name if files else ''}",
        *[pad + p.name for p in files[1:]],
        f"Bag size:          {_size(size)}",
        f"Storage id:        {storage}",
        f"ROS Distro:        {distro}",
        f"Duration:          {(end - start) / 1e9:.9f}s",
        f"Start:             {_when(start)}",
        f"End:               {_when(end)}",
        f"Messages:          {count}",
    ]
    rows = [
        f"Topic: {name} | Type: {info.msgtype} | Count: {info.msgcount} | Serialization Format: cdr"
        for name, info in sorted(topics.items())
    ]
    lines.append("Topic information: " + (rows[0] if rows else ""))
    lines += [pad + r for r in rows[1:]]
    lines.append("Service:           0")
    lines.append("Service information: ")
    return "\n".join(lines)

