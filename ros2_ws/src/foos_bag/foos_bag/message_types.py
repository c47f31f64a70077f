"""Message types: the Jazzy type store the project shares, the definitions of types it lacks, and the
names of the message types foos_bag writes."""
from __future__ import annotations

import functools
import os
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

from foos_core.stamps import seconds_to_stamp

from .errors import BagError

__all__ = [
    "DEFINITION_RULE", "FLOAT64_MULTI_ARRAY", "JOINT_STATE", "ODOMETRY", "POINT_STAMPED", "STRING",
    "header", "message_definition", "register_type", "typestore",
]

POINT_STAMPED = "geometry_msgs/msg/PointStamped"
ODOMETRY = "nav_msgs/msg/Odometry"
JOINT_STATE = "sensor_msgs/msg/JointState"
FLOAT64_MULTI_ARRAY = "std_msgs/msg/Float64MultiArray"
STRING = "std_msgs/msg/String"

# rosbag2 concatenates a type's definition with those of the types it uses, each block after a line of this.
DEFINITION_RULE = "=" * 80


@functools.cache
def typestore() -> Typestore:
    """The Jazzy type store shared by the project (message classes, CDR, definitions, hashes)."""
    return get_typestore(Stores.ROS2_JAZZY)


def register_type(msgtype: str, msgdef: str | None = None) -> None:
    """Make `msgtype` known to the type store, from a definition text or the installed .msg file."""
    store = typestore()
    if msgtype in store.types:
        return
    if msgdef is None:
        msgdef = _installed_msg_definition(msgtype)
    if msgdef is None:
        raise BagError(f"unknown message type {msgtype}: it is not a Jazzy type and no .msg file for it is installed")
    try:
        if msgdef.startswith(DEFINITION_RULE):
            # A concatenated definition (as stored in bags): the first block is the type itself.
            blocks = msgdef.split(DEFINITION_RULE + "\n")
            types = get_types_from_msg(blocks[0], msgtype)
            for block in blocks[1:]:
                block_header, _, text = block.partition("\n")
                if block_header.startswith("MSG: "):
                    name = block_header[5:].strip()
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
    package, _, name = msgtype.partition("/msg/")
    for prefix in os.environ.get("AMENT_PREFIX_PATH", "").split(os.pathsep):
        candidate = Path(prefix, "share", package, "msg", name + ".msg")
        if prefix and candidate.is_file():
            return candidate.read_text()
    return None


def message_definition(msgtype: str) -> tuple[str, str]:
    """(rosbag2 message definition text, RIHS01 type hash) of a message type."""
    register_type(msgtype)
    store = typestore()
    msgdef, _ = store.generate_msgdef(msgtype, ros_version=2)
    return msgdef, store.hash_rihs01(msgtype)


def header(seconds: float, frame_id: str):
    """A std_msgs/Header stamped `seconds` (rounded to the nanosecond) in `frame_id`."""
    types = typestore().types
    return types["std_msgs/msg/Header"](stamp=seconds_to_stamp(seconds, types["builtin_interfaces/msg/Time"]),
                                        frame_id=frame_id)
