"""metadata.yaml: rosbag2's description (version 9) of a bag's files and topics, and the QoS text that
rosbag2 stores with each topic."""
from __future__ import annotations

from collections.abc import Iterable, Sequence
from io import StringIO
from pathlib import Path
from typing import Any

from rosbags.interfaces import Qos
from rosbags.rosbag2.metadata import dump_qos_v9
from ruamel.yaml import YAML

__all__ = ["METADATA_FILE", "ROS_DISTRO", "build_metadata", "qos_string", "write_metadata", "yaml_text"]

METADATA_FILE = "metadata.yaml"
ROS_DISTRO = "jazzy"


def yaml_text(data: Any) -> str:
    """`data` as block-style YAML, the way rosbag2 writes it."""
    stream = StringIO()
    yaml = YAML(typ="safe")
    yaml.default_flow_style = False
    yaml.dump(data, stream)
    return stream.getvalue()


def qos_string(qos: Sequence[Qos]) -> str:
    """QoS profiles as the YAML text rosbag2 (metadata version 9) stores per topic."""
    if not qos:
        return ""
    return yaml_text(dump_qos_v9(list(qos))).strip()


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
    tmp = bag / (METADATA_FILE + ".tmp")
    tmp.write_text(yaml_text(metadata), "utf8")
    tmp.replace(bag / METADATA_FILE)
