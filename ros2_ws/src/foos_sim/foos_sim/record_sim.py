"""`ros2 run foos_sim record_sim OUT`: a "measured" bag made from the simulator, with no ROS running.

It runs foos_sim's SimRunner (the same schedule sim_node follows) as fast as the CPU allows and writes
what a camera and rod encoders on a real table would have produced:
  /ball/detection  PointStamped, stamp = capture time, received `--latency` later, Gaussian `--noise` on
                   x and y, `--dropout` probability of a missed frame (and no detection while the ball is
                   in a goal pocket)
  /joint_states    the 16 rod joints at --publish-rate
  /sim/goal        the scoring team at each goal
  and, with --truth-topic, the simulator's ground-truth ball state (nav_msgs/Odometry) for evaluation.
Times are simulated seconds from --start-time (0 = the epoch, as sim_node on sim time stamps them).
"""
from __future__ import annotations

import argparse
import sys

import numpy as np
from tqdm import tqdm

from foos_bag import (
    STORAGE_SUFFIX,
    STRING,
    BagError,
    BagWriter,
    typestore,
    write_ball_detections,
    write_ball_states,
    write_joint_states,
)
from foos_core.names import GOAL_TOPIC, JOINT_NAMES

from .sim_runner import SERVES, Detection, Goal, RunnerConfig, SimRunner, StateSample
from .simulation import TableSimulation


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="ros2 run foos_sim record_sim",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
        epilog="Example: ros2 run foos_sim record_sim measured1 --duration 60 --noise 0.002 --latency 0.03 "
        "--dropout 0.05 --seed 1 --params-file tilted.yaml --truth-topic /sim/ball_truth",
    )
    p.add_argument("output", help="bag directory to create (refused if it exists)")
    p.add_argument("--duration", type=float, default=10.0, help="simulated seconds (default 10)")
    p.add_argument("--params-file", default="", help="table parameter file for foos_sim (default: the nominal table)")
    p.add_argument("--serve", choices=SERVES, default="random", help="how balls are put in play")
    p.add_argument("--ball", type=float, nargs=4, metavar=("X", "Y", "VX", "VY"), default=(0.0, 0.0, 0.0, 0.0),
                   help="initial ball state for --serve none")
    p.add_argument("--seed", type=int, default=0, help="random seed (serves, noise, dropouts)")
    p.add_argument("--noise", type=float, default=0.002, help="detection noise std on x and y, m (default 0.002)")
    p.add_argument("--latency", type=float, default=0.03, help="capture-to-receive latency, s (default 0.03)")
    p.add_argument("--dropout", type=float, default=0.05, help="probability of a missed frame (default 0.05)")
    p.add_argument("--detection-rate", type=float, default=120.0, help="camera frames/s (default 120)")
    p.add_argument("--publish-rate", type=float, default=100.0, help="joint state rate, Hz (default 100)")
    p.add_argument("--truth-topic", default="", help="also write the ground-truth ball state on this topic")
    p.add_argument("--start-time", type=float, default=0.0, help="time of the first sample, s since the epoch")
    p.add_argument("-s", "--storage", choices=tuple(STORAGE_SUFFIX), default="mcap", help="bag storage (default mcap)")
    return p


def simulate(ns: argparse.Namespace):
    config = RunnerConfig(
        publish_rate=ns.publish_rate,
        detection_rate=ns.detection_rate,
        detection_noise=ns.noise,
        detection_latency=ns.latency,
        detection_dropout=ns.dropout,
        serve=ns.serve,
        initial_ball=tuple(ns.ball),
        seed=ns.seed,
    )
    try:
        sim = TableSimulation(ns.params_file or None)
        runner = SimRunner(sim, config)
    except (ValueError, OSError, KeyError) as exc:
        raise BagError(f"cannot start the simulation: {str(exc).splitlines()[0]}") from None
    samples, detections, goals = [], [], []
    fmt = "{l_bar}{bar}| {n:.1f}/{total:.1f} sim s [{elapsed}<{remaining}]"
    with tqdm(total=ns.duration, bar_format=fmt, desc="simulating", file=sys.stderr, leave=False) as bar:
        shown = 0.0
        while runner.time < ns.duration:
            for event in runner.advance():
                if isinstance(event, StateSample):
                    samples.append(event)
                elif isinstance(event, Detection):
                    detections.append(event)
                elif isinstance(event, Goal):
                    goals.append(event)
            if runner.time - shown >= 0.1:
                bar.update(runner.time - shown)
                shown = runner.time
    return JOINT_NAMES, samples, detections, goals


def write_bag(ns: argparse.Namespace, joint_names, samples, detections, goals) -> dict[str, int]:
    t0 = ns.start_time
    with BagWriter(ns.output, ns.storage, custom_data={"source": "foos_sim record_sim", "seed": str(ns.seed)}) as bag:
        if detections:
            write_ball_detections(
                bag,
                t0 + np.array([d.capture_time for d in detections]),
                np.array([d.position for d in detections]),
                latency=np.array([d.publish_time - d.capture_time for d in detections]),
            )
        if samples:
            t = t0 + np.array([s.time for s in samples])
            write_joint_states(
                bag, t, joint_names,
                np.array([s.joint_positions for s in samples]), np.array([s.joint_velocities for s in samples]),
            )
            if ns.truth_topic:
                write_ball_states(
                    bag, t, np.array([s.ball_position for s in samples]), np.array([s.ball_velocity for s in samples]),
                    topic=ns.truth_topic,
                )
        bag.add_topic(GOAL_TOPIC, STRING)
        string = typestore().types[STRING]
        for g in goals:
            bag.write(GOAL_TOPIC, int(round((t0 + g.time) * 1e9)), string(data=g.team))
        return bag.message_counts


def main(argv: list[str] | None = None) -> None:
    ns = build_parser().parse_args(sys.argv[1:] if argv is None else argv)
    problems = [
        (ns.duration <= 0, "--duration must be > 0"),
        (ns.noise < 0, "--noise must be >= 0"),
        (ns.latency < 0, "--latency must be >= 0"),
        (not 0 <= ns.dropout < 1, "--dropout must be in [0, 1)"),
        (ns.start_time < 0, "--start-time must be >= 0"),
        (ns.truth_topic and not ns.truth_topic.startswith("/"), "--truth-topic must start with /"),
    ]
    for bad, message in problems:
        if bad:
            print(f"record_sim: {message}", file=sys.stderr)
            sys.exit(2)
    try:
        BagWriter.check_new_path(ns.output)
        joint_names, samples, detections, goals = simulate(ns)
        counts = write_bag(ns, joint_names, samples, detections, goals)
    except BagError as exc:
        print(f"record_sim: {exc}", file=sys.stderr)
        sys.exit(1)
    except KeyboardInterrupt:
        print("record_sim: interrupted; no bag written", file=sys.stderr)
        sys.exit(130)
    print(f"wrote {ns.output}: " + ", ".join(f"{k} {v}" for k, v in counts.items()))


if __name__ == "__main__":
    main()
