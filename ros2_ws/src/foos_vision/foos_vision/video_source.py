"""video_source: publishes a video file or a camera device on /camera/image_raw, stamped with capture time.

File: stamp = start_time + frame index / fps (the contract's video time), published at the video's
rate (or as fast as possible with rate_factor 0). Device: stamp = the clock when the frame was grabbed.

    ros2 run foos_vision video_source --ros-args -p source:=game.mp4
    ros2 run foos_vision video_source --ros-args -p source:=0           # /dev/video0
"""
from __future__ import annotations

import sys
import time

import rclpy
from rclpy.node import Node
from sensor_msgs.msg import Image

from foos_core import node_signals

from .errors import VisionError
from .ros_common import seconds_to_stamp
from .video_io import VideoReader


class VideoSource(Node):
    def __init__(self, stop: node_signals.StopSignal):
        super().__init__("video_source")
        self.stop = stop
        self.declare_parameter("source", "")  # a video file, or a device index such as "0"
        self.declare_parameter("fps", 0.0)  # 0 = the container's frame rate
        self.declare_parameter("start_time", 0.0)  # s added to file frame times
        self.declare_parameter("rate_factor", 1.0)  # 1 = real time, 0 = as fast as possible
        self.declare_parameter("loop", False)
        self.declare_parameter("frame_id", "camera")
        # A file played before its consumers have matched loses its first frames, as `ros2 bag play`
        # does; wait_for_subscribers holds the first frame until that many subscribers are there.
        self.declare_parameter("wait_for_subscribers", 0)
        self.declare_parameter("wait_timeout", 30.0)
        source = self.get_parameter("source").value
        if not source:
            raise VisionError("set the `source` parameter to a video file or a camera index (-p source:=game.mp4)")
        self.is_device = str(source).isdigit()
        self.source = int(source) if self.is_device else str(source)
        self.fps = float(self.get_parameter("fps").value) or None
        self.start_time = float(self.get_parameter("start_time").value)
        self.rate_factor = float(self.get_parameter("rate_factor").value)
        self.loop = bool(self.get_parameter("loop").value)
        self.frame_id = self.get_parameter("frame_id").value
        self.wait_for_subscribers = int(self.get_parameter("wait_for_subscribers").value)
        self.wait_timeout = float(self.get_parameter("wait_timeout").value)
        self.reader = VideoReader(self.source, self.fps)
        self.publisher = self.create_publisher(Image, "/camera/image_raw", 10)
        self.published = 0
        self.get_logger().info(f"publishing {source} ({self.reader.width}x{self.reader.height} @ {self.reader.fps:g} fps)")

    def wait_for_consumers(self) -> None:
        deadline = time.monotonic() + self.wait_timeout
        while self.running() and self.publisher.get_subscription_count() < self.wait_for_subscribers:
            if time.monotonic() > deadline:
                raise VisionError(f"no {self.wait_for_subscribers} subscriber(s) on /camera/image_raw within "
                                  f"{self.wait_timeout:g} s (wait_for_subscribers)")
            rclpy.spin_once(self, timeout_sec=0.05)

    def running(self) -> bool:
        return rclpy.ok() and not self.stop.requested

    def run(self) -> None:
        """Publish every frame at its time; returns at the end of the file (unless looping)."""
        self.wait_for_consumers()
        offset = 0.0
        while self.running():
            wall_start = time.monotonic()
            last_t = 0.0
            for index, t, frame in self.reader.frames():
                if not self.running():
                    return
                if self.is_device:
                    stamp = self.get_clock().now().nanoseconds * 1e-9
                else:
                    stamp = self.start_time + offset + t
                    if self.rate_factor > 0:
                        delay = wall_start + t / self.rate_factor - time.monotonic()
                        if delay > 0:
                            time.sleep(delay)
                last_t = t
                self.publisher.publish(self._message(frame, stamp))
                self.published += 1
            if not self.loop or self.is_device:
                return
            offset += last_t + 1.0 / self.reader.fps
            self.reader.close()
            self.reader = VideoReader(self.source, self.fps)

    def _message(self, frame, stamp: float) -> Image:
        msg = Image()
        msg.header.stamp = seconds_to_stamp(stamp, type(msg.header.stamp))
        msg.header.frame_id = self.frame_id
        msg.height, msg.width = frame.shape[:2]
        msg.encoding = "bgr8"
        msg.step = msg.width * 3
        msg.data = frame.tobytes()
        return msg


def main(args=None) -> None:
    stop = node_signals.init(args)
    node = None
    code = 0
    try:
        node = VideoSource(stop)
        node.run()
        # Let late subscribers' reliable queues drain before the publisher goes away.
        end = time.monotonic() + 0.5
        while node.running() and time.monotonic() < end:
            rclpy.spin_once(node, timeout_sec=0.05)
        node.get_logger().info(f"{'stopped' if stop.requested else 'done'}: {node.published} frames published")
    except KeyboardInterrupt:  # a second Ctrl-C
        pass
    except (VisionError, ValueError, OSError) as error:
        print(f"video_source: error: {error}", file=sys.stderr)
        code = 2
    finally:
        if node is not None:
            node.destroy_node()
        rclpy.try_shutdown()
    sys.exit(code)


if __name__ == "__main__":
    main()
