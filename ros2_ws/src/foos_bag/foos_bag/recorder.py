"""The recorder: raw CDR from DDS into a rosbag2 bag (`ros2 bag record`, or `ros2 run foos_bag recorder`).

It subscribes with raw=True, so messages are stored byte for byte as they arrived, stamped with the
receive time. Topics are discovered on a timer, so topics that appear mid-run are picked up. Each
subscription matches its publishers' QoS. SIGINT and SIGTERM stop it cleanly: what was already received
is written and the bag is closed; a SIGKILL leaves a bag that `ros2 bag reindex` recovers.
"""
from __future__ import annotations

import re
import sys
import time
from dataclasses import dataclass, field
from functools import partial

from rclpy.clock import Clock, ClockType
from rclpy.exceptions import ParameterException
from rclpy.executors import Executor, SingleThreadedExecutor
from rclpy.experimental import EventsExecutor
from rclpy.node import Node
from rclpy.parameter import Parameter

from foos_core import node_signals
from foos_core.nodes import run_node

from .errors import BagError, first_line
from .ros_types import message_class, subscription_qos, to_bag_qos
from .writer import BagWriter


@dataclass
class RecordConfig:
    output: str
    topics: list[str] = field(default_factory=list)
    all_topics: bool = False
    regex: str = ""
    exclude_regex: str = ""
    include_hidden: bool = False
    storage: str = "mcap"
    max_bag_size: int = 0  # bytes, 0 = no split
    max_bag_duration: float = 0.0  # s, 0 = no split
    polling_interval: float = 0.1  # s between topic discoveries
    flush_interval: float = 0.1  # s, the most a SIGKILL can lose
    use_sim_time: bool = False
    executor: str = "single"  # "single" (rclpy's default) or "events" (rclpy.experimental, less overhead)


class TopicSelector:
    """Which discovered topics to record (ROS-free, so it is unit-testable)."""

    def __init__(self, config: RecordConfig) -> None:
        self.names = {self._absolute(t) for t in config.topics}
        self.all = config.all_topics
        self.regex = re.compile(config.regex) if config.regex else None
        self.exclude = re.compile(config.exclude_regex) if config.exclude_regex else None
        self.include_hidden = config.include_hidden

    @staticmethod
    def _absolute(topic: str) -> str:
        return topic if topic.startswith("/") else "/" + topic

    def wants(self, topic: str) -> bool:
        if self.exclude is not None and self.exclude.search(topic):
            return False
        if topic in self.names:
            return True
        hidden = any(part.startswith("_") for part in topic.split("/"))
        if hidden and not self.include_hidden:
            return False
        if self.all:
            return True
        return bool(self.regex is not None and self.regex.search(topic))


class Recorder(Node):
    """Subscribes to the selected topics as they appear and writes what arrives into a BagWriter."""

    def __init__(self, config: RecordConfig | None = None) -> None:
        super().__init__("foos_recorder")
        if config is None:
            config = self._config_from_parameters()
        elif config.use_sim_time:
            self.set_parameters([Parameter("use_sim_time", value=True)])
        self.config = config
        self.selector = TopicSelector(config)
        self.writer = BagWriter(
            config.output,
            config.storage,
            max_bag_size=config.max_bag_size,
            max_bag_duration=config.max_bag_duration,
            flush_interval=config.flush_interval,
        )
        self.received = 0
        self._subs_by_topic: dict[str, object] = {}
        self._skipped: set[str] = set()
        self._clock = self.get_clock()
        self.discover()
        # Discovery and flushing run on the steady clock: with use_sim_time the node's own clock stands still
        # until /clock arrives, and a player that waits for subscribers before it publishes /clock (ros2 bag
        # play --clock --wait-for-subscribers) would then wait for a recorder that never subscribes.
        steady = Clock(clock_type=ClockType.STEADY_TIME)
        self.create_timer(config.polling_interval, self.discover, clock=steady)
        self.create_timer(config.flush_interval, self.writer.flush, clock=steady)
        what = "all topics" if config.all_topics else ", ".join(sorted(self.selector.names)) or config.regex
        self.get_logger().info(f"Recording {what} into {config.output} ({config.storage})")

    def _config_from_parameters(self) -> RecordConfig:
        """The node form takes everything as ROS parameters, declared up front."""
        p = {
            "output": "",
            "topics": [""],
            "all": False,
            "regex": "",
            "exclude_regex": "",
            "include_hidden": False,
            "storage": "mcap",
            "max_bag_size": 0,
            "max_bag_duration": 0.0,
            "polling_interval": 0.1,
            "flush_interval": 0.1,
            "executor": "single",
        }
        for name, default in p.items():
            self.declare_parameter(name, default)
        get = lambda n: self.get_parameter(n).value  # noqa: E731
        output = get("output") or time.strftime("rosbag2_%Y_%m_%d-%H_%M_%S")
        topics = [t for t in get("topics") if t]
        if not topics and not get("all") and not get("regex"):
            raise BagError("nothing to record: set the parameter topics:=[...], all:=true or regex:=...")
        return RecordConfig(
            output=output,
            topics=topics,
            all_topics=get("all"),
            regex=get("regex"),
            exclude_regex=get("exclude_regex"),
            include_hidden=get("include_hidden"),
            storage=get("storage"),
            max_bag_size=int(get("max_bag_size")),
            max_bag_duration=float(get("max_bag_duration")),
            polling_interval=float(get("polling_interval")),
            flush_interval=float(get("flush_interval")),
            use_sim_time=bool(self.get_parameter("use_sim_time").value),
            executor=get("executor"),
        )

    def discover(self) -> None:
        for topic, types in self.get_topic_names_and_types():
            if topic in self._subs_by_topic or topic in self._skipped or not self.selector.wants(topic):
                continue
            publishers = self.get_publishers_info_by_topic(topic)
            if not publishers:
                continue  # only subscribers so far: their QoS says nothing about what will be offered
            self._subscribe(topic, types, publishers)

    def _subscribe(self, topic: str, types: list[str], publishers) -> None:
        if len(types) != 1:
            self.get_logger().warning(f"Not recording {topic}: it carries several types {types}")
            self._skipped.add(topic)
            return
        msgtype = types[0]
        cls = message_class(msgtype)
        if cls is None:
            self.get_logger().warning(f"Not recording {topic}: no Python support for {msgtype} is installed")
            self._skipped.add(topic)
            return
        try:
            self.writer.add_topic(topic, msgtype, qos=[to_bag_qos(p.qos_profile) for p in publishers])
        except BagError as exc:
            self.get_logger().warning(f"Not recording {topic}: {exc}")
            self._skipped.add(topic)
            return
        qos = subscription_qos([p.qos_profile for p in publishers])
        self._subs_by_topic[topic] = self.create_subscription(cls, topic, partial(self._store, topic), qos, raw=True)
        self.get_logger().info(f"Subscribed to topic '{topic}' ({msgtype})")

    def _store(self, topic: str, cdr: bytes) -> None:
        self.writer.write_raw(topic, self._clock.now().nanoseconds, cdr)
        self.received += 1

    def drain(self, executor, seconds: float = 0.3) -> None:
        """Take what DDS already delivered to our readers, so nothing received before a stop is lost."""
        deadline = time.monotonic() + seconds
        while time.monotonic() < deadline:
            before = self.received
            executor.spin_once(timeout_sec=0.02)
            if self.received == before:
                break

    def finish(self) -> None:
        self.writer.close()
        counts = self.writer.message_counts
        self.get_logger().info(
            f"Recording stopped: {sum(counts.values())} messages on {len(counts)} topics in {self.config.output}"
        )


class BadParameter(ValueError):
    """A ROS parameter of the recorder node has a value it cannot take."""


def make_executor(kind: str) -> Executor:
    if kind == "events":
        return EventsExecutor()
    if kind != "single":
        raise BagError(f"unknown executor {kind!r}: use 'single' or 'events'")
    return SingleThreadedExecutor()


def record(recorder: Recorder, executor: Executor, stop: node_signals.StopSignal) -> None:
    """Spin until SIGINT/SIGTERM, then write what DDS already delivered and close the bag."""
    node_signals.spin_until_stopped(executor, stop)
    recorder.drain(executor)
    recorder.finish()


def run(config: RecordConfig | None, args: list[str] | None = None) -> int:
    """Record until SIGINT/SIGTERM. Returns the exit code; errors are one line on stderr.

    The bag is always closed by us, in order: a signal, the first or a later one, only sets the flag that
    the spin loop checks (repeat_quits=False). On any error the writer is closed with what was recorded.
    """
    recorders: list[Recorder] = []  # the executor is made after the node, whose config names its kind

    def make_recorder() -> Recorder:
        try:
            recorders.append(Recorder(config))
        except ParameterException as exc:  # e.g. -p output:=N, which YAML reads as the boolean false
            raise BadParameter(f"bad parameter: {first_line(exc)} (quote strings: -p output:=\"'N'\")") from None
        return recorders[0]

    return run_node(
        "record",
        make_recorder,
        run=record,
        errors={BagError: 1, BadParameter: 2},
        on_exit=lambda recorder: recorder.writer.close(),  # a no-op after finish()
        make_executor=lambda: make_executor(recorders[0].config.executor),
        args=args,
        repeat_quits=False,
    )


def main(args: list[str] | None = None) -> None:
    """`ros2 run foos_bag recorder --ros-args -p topics:="['/ball/detection']" -p output:=run1`"""
    if any(a in ("-h", "--help") for a in sys.argv[1:]):
        print(
            "usage: ros2 run foos_bag recorder --ros-args -p output:=BAG (-p topics:=\"['/a','/b']\" | -p all:=true"
            " | -p regex:=RE)\n  [-p storage:=mcap|sqlite3] [-p max_bag_size:=BYTES] [-p max_bag_duration:=S]"
            " [-p exclude_regex:=RE]\n  [-p polling_interval:=S] [-p flush_interval:=S] [-p use_sim_time:=true]\n"
            "The same recorder as `ros2 bag record`, as a node taking ROS parameters. Stop it with Ctrl-C or SIGTERM."
        )
        return
    sys.exit(run(None, args if args is not None else sys.argv))

