"""foos_bag: rosbag2 bags without rosbag2_py: record, play, info, and numpy readers and writers.

The nodes (`recorder`, `player`, `load_publisher`) and the `ros2 bag` stand-in (`cli`) are the ROS side;
the readers and writers are plain Python on rosbags and mcap, and are what other packages import from
here. Modules, one concern each, bottom up:

  errors          BagError, the one exception; its message is one line that says what to do
  message_types   the shared Jazzy type store, definitions of types it lacks, message type names
  metadata        metadata.yaml (rosbag2 version 9)
  storage         MCAP and sqlite3 files flushed on a timer, so a crash leaves a repairable bag
  writer          BagWriter: topics and messages into a bag, split by size or duration
  reader          open_reader, topics, messages: a bag's messages in receive-time order
  array_writers   numpy arrays as ball detections, ball states and joint states
  array_readers   a bag's topics as numpy arrays sorted by stamp
  info, repair    `ros2 bag info` and `ros2 bag reindex` (ROS-free)
  ros_types, recorder, player, load_publisher, cli: the ROS side
"""
from .array_readers import (
    BallDetections,
    BallStates,
    Commands,
    JointStates,
    read_ball_detections,
    read_ball_states,
    read_commands,
    read_goals,
    read_joint_states,
)
from .array_writers import write_ball_detections, write_ball_states, write_joint_states
from .errors import BagError
from .message_types import FLOAT64_MULTI_ARRAY, JOINT_STATE, ODOMETRY, POINT_STAMPED, STRING, typestore
from .reader import messages, open_reader, topics
from .storage import STORAGE_SUFFIX, storage_files
from .writer import BagWriter

__all__ = [
    "FLOAT64_MULTI_ARRAY", "JOINT_STATE", "ODOMETRY", "POINT_STAMPED", "STORAGE_SUFFIX", "STRING",
    "BagError", "BagWriter", "BallDetections", "BallStates", "Commands", "JointStates",
    "messages", "open_reader", "read_ball_detections", "read_ball_states", "read_commands", "read_goals",
    "read_joint_states", "storage_files", "topics", "typestore", "write_ball_detections", "write_ball_states",
    "write_joint_states",
]
