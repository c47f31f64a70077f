"""foos_bag: rosbag2 bags without rosbag2_py: record, play, info, and numpy readers and writers.

The nodes (`recorder`, `player`, `load_publisher`) and the `ros2 bag` stand-in (`cli`) are the ROS side;
the readers and writers below are plain Python on rosbags and mcap, and are what other packages import.
"""
from .bag_io import (
    STORAGE_SUFFIX,
    BagError,
    BagWriter,
    BallDetections,
    BallStates,
    Commands,
    JointStates,
    messages,
    open_reader,
    read_ball_detections,
    read_ball_states,
    read_commands,
    read_goals,
    read_joint_states,
    storage_files,
    topics,
    typestore,
    write_ball_detections,
    write_ball_states,
    write_joint_states,
)

__all__ = [
    "STORAGE_SUFFIX", "BagError", "BagWriter", "BallDetections", "BallStates", "Commands", "JointStates",
    "messages", "open_reader", "read_ball_detections", "read_ball_states", "read_commands", "read_goals",
    "read_joint_states", "storage_files", "topics", "typestore", "write_ball_detections", "write_ball_states",
    "write_joint_states",
]
