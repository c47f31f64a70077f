"""The player: a rosbag2 bag back onto DDS (`ros2 bag play BAG`, or `ros2 run foos_bag player BAG`).

Messages are published as the raw CDR bytes that were recorded, at their recorded receive times
(scaled by --rate), optionally looping, filtered by topic, remapped, and with /clock carrying the bag
time so nodes with use_sim_time follow the recording.
"""
from __future__ import annotations

import argparse
import signal
import sys
import time
from dataclasses import dataclass, field

import rclpy
from rclpy.node import Node
from rclpy.qos import QoSProfile
from rclpy.signals import SignalHandlerOptions
from rosgraph_msgs.msg import Clock

from foos_core.names import CLOCK_TOPIC

from .errors import BagError
from .reader import check_topics, damaged_file_errors, open_reader
from .ros_types import message_class, publisher_qos


@dataclass
class PlayConfig:
    bag: str
    rate: float = 1.0
    loop: bool = False
    topics: list[str] = field(default_factory=list)
    remaps: dict[str, str] = field(default_factory=dict)
    clock_hz: float = 0.0  # 0 = no /clock
    delay: float = 0.0  # s to wait after creating publishers, so subscribers can match
    start_offset: float = 0.0  # s into the bag to start from
    wait_subscribers: int = 0  # wait until every topic has this many subscribers before playing
    wait_timeout: float = 30.0


def parse_remaps(items: list[str]) -> dict[str, str]:
    """['/a:=/b', ...] -> {'/a': '/b'}; a malformed item is a BagError."""
    remaps: dict[str, str] = {}
    for item in items:
        old, sep, new = item.partition(":=")
        if not sep or not old or not new:
            raise BagError(f"bad remap {item!r}: write it as /old_topic:=/new_topic")
        remaps[old if old.startswith("/") else "/" + old] = new if new.startswith("/") else "/" + new
    return remaps


def due_time(start_wall: float, bag_start_ns: int, stamp_ns: int, rate: float) -> float:
    """Wall time (time.monotonic) at which a message recorded at stamp_ns is to be published."""
    return start_wall + (stamp_ns - bag_start_ns) * 1e-9 / rate


class Player(Node):
    """Publishes a bag's messages with their recorded timing."""

    def __init__(self, config: PlayConfig) -> None:
        super().__init__("foos_player")
        if config.rate <= 0:
            raise BagError(f"--rate must be > 0, not {config.rate}")
        self.config = config
        reader = open_reader(config.bag)
        try:
            conns = list(reader.connections)  # rosbags clears its own list on close
            self.bag_start_ns = reader.start_time if reader.message_count else 0
        finally:
            reader.close()
        check_topics(config.bag, config.topics, (c.topic for c in conns))
        self.publishers_by_topic = {}
        for conn in conns:
            if config.topics and conn.topic not in config.topics:
                continue
            cls = message_class(conn.msgtype)
            if cls is None:
                self.get_logger().warning(f"Not playing {conn.topic}: no Python support for {conn.msgtype}")
                continue
            out = config.remaps.get(conn.topic, conn.topic)
            qos = publisher_qos(list(conn.ext.offered_qos_profiles))
            self.publishers_by_topic[conn.topic] = self.create_publisher(cls, out, qos)
        if not self.publishers_by_topic:
            raise BagError(f"nothing to play from {config.bag}: no playable topics selected")
        self.clock_pub = None
        if config.clock_hz > 0:
            self.clock_pub = self.create_publisher(Clock, CLOCK_TOPIC, QoSProfile(depth=10))
            self._clock_msg = Clock()
        self.published = 0
        self.stop = False

    def publish_clock(self, bag_ns: int) -> None:
        self._clock_msg.clock.sec, self._clock_msg.clock.nanosec = divmod(int(bag_ns), 1_000_000_000)
        self.clock_pub.publish(self._clock_msg)

    def _wait_until(self, due: float, start_wall: float) -> None:
        """Sleep until `due`, publishing /clock on its period meanwhile."""
        period = 1.0 / self.config.clock_hz if self.clock_pub is not None else None
        while not self.stop:
            now = time.monotonic()
            if self.clock_pub is not None and now >= self._next_clock:
                bag_ns = self.bag_start_ns + (now - start_wall) * self.config.rate * 1e9
                self.publish_clock(bag_ns)
                self._next_clock = now + period
            remaining = due - now
            if remaining <= 0:
                return
            wake = remaining if period is None else min(remaining, self._next_clock - now)
            time.sleep(max(0.0, min(wake, 0.05)))

    def play_once(self) -> None:
        cfg = self.config
        reader = open_reader(cfg.bag)
        try:
            conns = [c for c in reader.connections if c.topic in self.publishers_by_topic]
            first_ns = self.bag_start_ns + int(cfg.start_offset * 1e9)
            start_wall = time.monotonic()
            self._next_clock = start_wall
            with damaged_file_errors(cfg.bag, "playing"):
                for conn, stamp, data in reader.messages(connections=conns, start=first_ns):
                    self._wait_until(due_time(start_wall, first_ns, stamp, cfg.rate), start_wall)
                    if self.stop:
                        return
                    self.publishers_by_topic[conn.topic].publish(bytes(data))
                    self.published += 1
        finally:
            reader.close()

    def wait_for_subscribers(self) -> None:
        """Block until every publisher has `wait_subscribers` matched subscriptions (BagError on timeout)."""
        need, end = self.config.wait_subscribers, time.monotonic() + self.config.wait_timeout
        while not self.stop:
            lacking = [t for t, p in self.publishers_by_topic.items() if p.get_subscription_count() < need]
            if not lacking:
                return
            if time.monotonic() > end:
                raise BagError(f"no {need} subscriber(s) on {', '.join(lacking)} after {self.config.wait_timeout:g} s")
            time.sleep(0.02)

    def play(self) -> None:
        if self.config.wait_subscribers > 0:
            self.wait_for_subscribers()
        if self.config.delay > 0:
            self._sleep(self.config.delay)
        while not self.stop:
            self.play_once()
            if not self.config.loop:
                break

    def _sleep(self, seconds: float) -> None:
        end = time.monotonic() + seconds
        while not self.stop and time.monotonic() < end:
            time.sleep(min(0.05, end - time.monotonic()))


def build_parser(prog: str = "ros2 bag play") -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog=prog,
        description="Publish the messages of a rosbag2 bag (MCAP or sqlite3) with their recorded timing.",
        epilog="Example: ros2 bag play run1 --rate 2 --topics /ball/detection --remap /ball/detection:=/replay/det",
    )
    p.add_argument("bag", help="bag directory (or a single .mcap/.db3 file)")
    p.add_argument("-r", "--rate", type=float, default=1.0, help="playback speed factor (2 = twice as fast)")
    p.add_argument("-l", "--loop", action="store_true", help="start again at the end, until Ctrl-C")
    p.add_argument("--topics", nargs="+", default=[], metavar="TOPIC", help="play only these topics")
    p.add_argument(
        "--remap", "-m", nargs="+", default=[], metavar="OLD:=NEW", help="publish topic OLD under the name NEW"
    )
    p.add_argument(
        "--clock", nargs="?", type=float, const=40.0, default=0.0, metavar="HZ",
        help="publish /clock with the bag time at HZ (default 40 when given without a value)",
    )
    p.add_argument("-d", "--delay", type=float, default=0.0, help="seconds to wait before playing, so subscribers match")
    p.add_argument("--start-offset", type=float, default=0.0, help="start this many seconds into the bag")
    p.add_argument("--wait-for-subscribers", type=int, default=0, metavar="N",
                   help="before playing, wait until every played topic has N subscribers (e.g. a recorder)")
    p.add_argument("--wait-timeout", type=float, default=30.0, help="give up waiting for subscribers after S seconds")
    return p


def config_from_args(ns: argparse.Namespace) -> PlayConfig:
    return PlayConfig(
        bag=ns.bag,
        rate=ns.rate,
        loop=ns.loop,
        topics=[t if t.startswith("/") else "/" + t for t in ns.topics],
        remaps=parse_remaps(ns.remap),
        clock_hz=ns.clock,
        delay=ns.delay,
        start_offset=ns.start_offset,
        wait_subscribers=ns.wait_for_subscribers,
        wait_timeout=ns.wait_timeout,
    )


def run(config: PlayConfig, ros_args: list[str] | None = None) -> int:
    rclpy.init(args=ros_args, signal_handler_options=SignalHandlerOptions.NO)
    player = None

    def stop(_signum, _frame):
        if player is not None:
            player.stop = True

    signal.signal(signal.SIGINT, stop)
    signal.signal(signal.SIGTERM, stop)
    try:
        player = Player(config)
        player.play()
        player.get_logger().info(f"Played {player.published} messages from {config.bag}")
        return 0
    except BagError as exc:
        print(f"play: {exc}", file=sys.stderr)
        return 1
    finally:
        if player is not None:
            player.destroy_node()
        rclpy.try_shutdown()  # a signal may already have shut the context down


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    ros_args: list[str] = []
    if "--ros-args" in argv:
        i = argv.index("--ros-args")
        argv, ros_args = argv[:i], argv[i:]
    ns = build_parser("ros2 run foos_bag player").parse_args(argv)
    try:
        config = config_from_args(ns)
    except BagError as exc:
        print(f"play: {exc}", file=sys.stderr)
        sys.exit(2)
    sys.exit(run(config, ["player", *ros_args]))
