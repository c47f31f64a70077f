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
from rclpy.executors import Executor
from rclpy.node import Node
from sensor_msgs.msg import Image

from foos_core.names import CAMERA_IMAGE_TOPIC
from foos_core.node_signals import StopSignal
from foos_core.nodes import run_node
from foos_core.stamps import seconds_to_stamp

from .errors import VisionError
from .video_io import VideoReader

DRAIN_S = 0.5  # after the last frame, late subscribers' reliable queues drain this long before the publisher goes


class VideoSource(Node):
    def __init__(self):
        super().__init__("video_source")
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
        self.publisher = self.create_publisher(Image, CAMERA_IMAGE_TOPIC, 10)
        self.published = 0
        self.get_logger().info(f"publishing {source} ({self.reader.width}x{self.reader.height} @ {self.reader.fps:g} fps)")

    def run(self, executor: Executor, stop: StopSignal) -> None:
        """run_node's run: publish the source, let late subscribers' reliable queues drain, say how it ended."""
        self._publish_all(executor, stop)
        end = time.monotonic() + DRAIN_S
        while self._running(stop) and time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
        self.get_logger().info(f"{'stopped' if stop.requested else 'done'}: {self.published} frames published")

    def _wait_for_consumers(self, executor: Executor, stop: StopSignal) -> None:
        deadline = time.monotonic() + self.wait_timeout
        while self._running(stop) and self.publisher.get_subscription_count() < self.wait_for_subscribers:
            if time.monotonic() > deadline:
                raise VisionError(f"no {self.wait_for_subscribers} subscriber(s) on {CAMERA_IMAGE_TOPIC} within "
                                  f"{self.wait_timeout:g} s (wait_for_subscribers)")
            executor.spin_once(timeout_sec=0.05)

    @staticmethod
    def _running(stop: StopSignal) -> bool:
        return rclpy.ok() and not stop.requested

    def _publish_all(self, executor: Executor, stop: StopSignal) -> None:
        """Publish every frame at its time; returns at the end of the file (unless looping)."""
        self._wait_for_consumers(executor, stop)
        offset = 0.0
        while self._running(stop):
            wall_start = time.monotonic()
            last_t = 0.0
            for _, t, frame in self.reader.frames():
                if not self._running(stop):
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


def main(args=None) -> int:
    return run_node("video_source", VideoSource, run=VideoSource.run, args=args,
                    errors=(VisionError, ValueError, OSError))


if __name__ == "__main__":
    sys.exit(main())
