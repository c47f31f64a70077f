"""`ros2 bag` for machines without ros2cli: record, play, info, reindex (the stand-in execs `ros2_bag`)."""
from __future__ import annotations

import argparse
import os
import sys
import time

from . import player, recorder
from .errors import BagError
from .info import summary
from .metadata import METADATA_FILE
from .repair import reindex
from .storage import STORAGE_SUFFIX

USAGE = """usage: ros2 bag <verb> [options]

verbs:
  record   record topics from DDS into a new bag          (ros2 bag record -a -o run1)
  play     publish a bag's messages with recorded timing  (ros2 bag play run1 --rate 2 --loop)
  info     summarise a bag                                (ros2 bag info run1)
  reindex  rebuild metadata and repair a bag whose recorder was killed (ros2 bag reindex run1)

`ros2 bag <verb> --help` explains each verb. Bags are rosbag2 directories (MCAP by default, sqlite3 with
-s sqlite3) that real ros2 bag, Foxglove and the mcap CLI open.
"""


def _die(verb: str, message: str, code: int = 1) -> None:
    print(f"ros2 bag {verb}: {message}", file=sys.stderr)
    sys.exit(code)


def record_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="ros2 bag record",
        description="Record topics from DDS into a new rosbag2 bag, storing each message's CDR bytes as "
        "received. Topics that appear while recording are picked up. Stop with Ctrl-C or SIGTERM: the bag "
        "is closed with everything received. After a crash or SIGKILL, run `ros2 bag reindex BAG`.",
        epilog="Examples: ros2 bag record -a -o run1 | ros2 bag record /ball/detection /joint_states -s sqlite3 "
        "| ros2 bag record -a -d 60 -o long_run (a new file each minute)",
    )
    p.add_argument("topics", nargs="*", help="topics to record (they may not exist yet)")
    p.add_argument("-a", "--all", action="store_true", help="record every topic, including ones that appear later")
    p.add_argument("-e", "--regex", default="", help="also record topics matching this regular expression")
    p.add_argument("-x", "--exclude-regex", default="", help="never record topics matching this regular expression")
    p.add_argument("--include-hidden-topics", action="store_true", help="with -a/-e, also record hidden topics (/_...)")
    p.add_argument("-o", "--output", default="", help="bag directory to create (default rosbag2_<date>-<time>); "
                   "an existing path is refused, never overwritten")
    p.add_argument("-s", "--storage", default="mcap", choices=sorted(STORAGE_SUFFIX), help="storage format (default mcap)")
    p.add_argument("-b", "--max-bag-size", type=int, default=0, help="start a new file after this many bytes (0 = never)")
    p.add_argument("-d", "--max-bag-duration", type=float, default=0.0, help="start a new file after this many seconds (0 = never)")
    p.add_argument("--polling-interval", type=float, default=100.0, help="ms between looks for new topics (default 100)")
    p.add_argument("--flush-interval", type=float, default=0.1, help="s between flushes to disk: the most a SIGKILL "
                   "can lose (default 0.1)")
    p.add_argument("--use-sim-time", action="store_true", help="stamp messages with /clock time instead of wall time")
    p.add_argument("--executor", choices=("single", "events"), default="single",
                   help="rclpy executor: 'single' (default) or 'events' (rclpy's experimental EventsExecutor, "
                   "less overhead per message; see scripts/bench_bag)")
    return p


def cmd_record(argv: list[str]) -> None:
    ns = record_parser().parse_args(argv)
    if not ns.topics and not ns.all and not ns.regex:
        _die("record", "nothing to record: name topics, or use -a/--all or -e/--regex", 2)
    if ns.polling_interval <= 0 or ns.flush_interval <= 0:
        _die("record", "--polling-interval and --flush-interval must be > 0", 2)
    output = ns.output or time.strftime("rosbag2_%Y_%m_%d-%H_%M_%S")
    if os.path.exists(output):
        _die("record", f"{output} exists already; refusing to overwrite it (choose another -o)")
    config = recorder.RecordConfig(
        output=output,
        topics=ns.topics,
        all_topics=ns.all,
        regex=ns.regex,
        exclude_regex=ns.exclude_regex,
        include_hidden=ns.include_hidden_topics,
        storage=ns.storage,
        max_bag_size=ns.max_bag_size,
        max_bag_duration=ns.max_bag_duration,
        polling_interval=ns.polling_interval / 1000.0,
        flush_interval=ns.flush_interval,
        use_sim_time=ns.use_sim_time,
        executor=ns.executor,
    )
    sys.exit(recorder.run(config, ["ros2_bag_record"]))


def cmd_play(argv: list[str]) -> None:
    ns = player.build_parser().parse_args(argv)
    try:
        config = player.config_from_args(ns)
    except BagError as exc:
        _die("play", str(exc), 2)
    sys.exit(player.run(config, ["ros2_bag_play"]))


def cmd_info(argv: list[str]) -> None:
    p = argparse.ArgumentParser(prog="ros2 bag info", description="Print a bag's files, size, time span and "
                                "per-topic message counts and types.")
    p.add_argument("bag", help="bag directory (or a single .mcap/.db3 file)")
    ns = p.parse_args(argv)
    try:
        print(summary(ns.bag))
    except BagError as exc:
        _die("info", str(exc))


def cmd_reindex(argv: list[str]) -> None:
    p = argparse.ArgumentParser(
        prog="ros2 bag reindex",
        description="Rebuild metadata.yaml of a bag whose recorder was killed (SIGKILL, power loss), and repair "
        "its MCAP files: every record that reached the disk is kept; a damaged original is kept as "
        "*.mcap.broken. Messages not yet flushed when the recorder died (at most its flush interval, "
        "0.1 s by default) cannot be recovered. See docs/bags.md.",
    )
    p.add_argument("bag", help="bag directory")
    ns = p.parse_args(argv)
    try:
        reports = reindex(ns.bag)
    except BagError as exc:
        _die("reindex", str(exc))
    for r in reports:
        print(f"{r.path}: {r.status}, {r.messages} messages" + (f" ({r.note})" if r.note else ""))
    print(f"wrote {os.path.join(ns.bag, METADATA_FILE)}")


VERBS = {"record": cmd_record, "play": cmd_play, "info": cmd_info, "reindex": cmd_reindex}


def main(argv: list[str] | None = None) -> None:
    argv = sys.argv[1:] if argv is None else argv
    if not argv or argv[0] in ("-h", "--help"):
        print(USAGE.strip())
        sys.exit(0 if argv else 2)
    verb = VERBS.get(argv[0])
    if verb is None:
        _die(argv[0], f"unknown verb; this stand-in offers: {', '.join(VERBS)}", 2)
    try:
        verb(argv[1:])
    except KeyboardInterrupt:
        sys.exit(130)


if __name__ == "__main__":
    main()
