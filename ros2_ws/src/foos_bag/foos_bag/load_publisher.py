"""A numbered-message publisher for recorder benchmarks and fault tests (`ros2 run foos_bag load_publisher`).

Publishes geometry_msgs/PointStamped on /load/t0../load/t{N-1} at a fixed rate; point.x is the sequence
number and the header stamp the publish time, so a recording can be checked message by message against
the JSON log written at the end (`--log`).
"""
from __future__ import annotations

import argparse
import json
import sys
import time

import rclpy
from geometry_msgs.msg import PointStamped
from rclpy.node import Node
from rclpy.qos import HistoryPolicy, QoSProfile, ReliabilityPolicy

from foos_core import node_signals


class LoadPublisher(Node):
    def __init__(self, n_topics: int, best_effort: bool) -> None:
        super().__init__("foos_load_publisher")
        qos = QoSProfile(
            history=HistoryPolicy.KEEP_LAST,
            depth=1000,
            reliability=ReliabilityPolicy.BEST_EFFORT if best_effort else ReliabilityPolicy.RELIABLE,
        )
        self.pubs = [self.create_publisher(PointStamped, f"/load/t{i}", qos) for i in range(n_topics)]

    def wait_for_subscribers(self, count: int, timeout: float) -> bool:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if all(p.get_subscription_count() >= count for p in self.pubs):
                return True
            time.sleep(0.02)
        return False


def main(argv: list[str] | None = None) -> None:
    p = argparse.ArgumentParser(prog="ros2 run foos_bag load_publisher", description=__doc__)
    p.add_argument("--rate", type=float, default=1000.0, help="messages/s per topic")
    p.add_argument("--topics", type=int, default=3, help="number of topics /load/t0..")
    p.add_argument("--duration", type=float, default=10.0, help="seconds to publish (Ctrl-C stops earlier)")
    p.add_argument("--wait-subscribers", type=int, default=0, help="first wait until every topic has this many subscribers")
    p.add_argument("--wait-timeout", type=float, default=20.0, help="give up waiting after this many seconds")
    p.add_argument("--best-effort", action="store_true", help="publish best-effort instead of reliable")
    p.add_argument("--log", default="", help="write a JSON log: per topic the publish times (ns) by sequence number")
    ns = p.parse_args(sys.argv[1:] if argv is None else argv)
    if ns.rate <= 0 or ns.topics < 1 or ns.duration <= 0:
        print("load_publisher: --rate, --topics and --duration must be > 0", file=sys.stderr)
        sys.exit(2)

    # A second Ctrl-C stops it the same way: the log of what was published is still written.
    stop = node_signals.init(repeat_quits=False)
    node = LoadPublisher(ns.topics, ns.best_effort)
    times: list[list[int]] = [[] for _ in range(ns.topics)]
    try:
        if ns.wait_subscribers and not node.wait_for_subscribers(ns.wait_subscribers, ns.wait_timeout):
            print("load_publisher: subscribers did not appear in time", file=sys.stderr)
            sys.exit(1)
        msg = PointStamped()
        msg.header.frame_id = "load"
        period = 1.0 / ns.rate
        total = int(round(ns.duration * ns.rate))
        start = time.monotonic()
        for seq in range(total):
            due = start + seq * period
            delay = due - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            if stop.requested:
                break
            now = time.time_ns()
            msg.header.stamp.sec, msg.header.stamp.nanosec = divmod(now, 1_000_000_000)
            msg.point.x = float(seq)
            for i, pub in enumerate(node.pubs):
                pub.publish(msg)
                times[i].append(now)
        elapsed = time.monotonic() - start
        sent = sum(len(t) for t in times)
        print(f"load_publisher: published {sent} messages in {elapsed:.2f} s ({sent / elapsed:.0f} msg/s)")
        time.sleep(0.5)  # let reliable delivery finish before the writers go away
    finally:
        if ns.log:
            with open(ns.log, "w") as f:
                json.dump({f"/load/t{i}": t for i, t in enumerate(times)}, f)
        node.destroy_node()
        rclpy.shutdown()


if __name__ == "__main__":
    main()
