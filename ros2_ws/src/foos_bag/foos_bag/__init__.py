"""rosbag2 record, play, info and a numpy reader (filled by the bags issue)."""
