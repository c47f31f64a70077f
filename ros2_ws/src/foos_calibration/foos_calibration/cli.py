"""`ros2 run foos_calibration calibrate BAG --out DIR`: what the simulation gets wrong, why, and the gain."""
from __future__ import annotations

import argparse
import os
import sys
from pathlib import Path
from typing import Sequence

from foos_core.names import TEAMS, command_topic
from foos_core.table_params import ParamsError

os.environ.setdefault("OMP_NUM_THREADS", "1")
os.environ.setdefault("OPENBLAS_NUM_THREADS", "1")

DESCRIPTION = """\
Calibrate the simulated table against measured ball motion.

Reads /ball/detection (geometry_msgs/PointStamped, frame `table`) from a rosbag2 directory, replays
the measured rolls on the nominal MuJoCo table, names the effects the data supports from the
contract's vocabulary (table_tilt, rolling_resistance, viscous_damping, air_drag, surface_dent,
wall_restitution), fits them as physical extensions of the MuJoCo model, and measures the gain on
held-out data. Writes to DIR:
  report.json            effects with parameters and evidence, baseline/calibrated errors (contract schema)
  report.md              the same in words, with the figures
  calibrated_table.yaml  the fitted table: load_model(path), or sim_node -p params_file:=path
  residual_map.png, deceleration_vs_speed.png, wall_bounces.png, tracks.png
A game recording also has /joint_states and /home/rods/command, /away/rods/command: the rod drives are
then identified first (rod_latency, rod_speed_limit, rod_acceleration_limit; report.json `rods`), and
reported even when the ball side cannot be calibrated (report.json `ball_skipped` says why).
"""

EPILOG = """\
Good data: a minute or more of free rolls launched by hand at 0.3-3 m/s from many places, with the
rods turned up (figures horizontal) so the ball meets only the walls. Gaps are fine.
Example:
  ros2 run foos_calibration calibrate bags/demo/measured --out out/calibration
Exit status: 0 done, 2 bad input (one-line reason on stderr).
"""


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="calibrate", description=DESCRIPTION, epilog=EPILOG,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("bag", help="rosbag2 directory (MCAP or sqlite3) with /ball/detection")
    parser.add_argument("--out", required=True, metavar="DIR", help="output directory (created; files in it are replaced)")
    parser.add_argument("--base", metavar="PARAMS", help="parameter file of the table to start from "
                        "(default: the regulation table); e.g. a calibrated file, to check it explains new data")
    parser.add_argument("--topic", default="/ball/detection", help="detection topic (default /ball/detection)")
    parser.add_argument("--max-starts", type=int, default=40, help="held-out prediction starts to evaluate (default 40)")
    parser.add_argument("--seed", type=int, default=0, help="seed for start sampling and bootstrap (default 0)")
    parser.add_argument("--no-figures", action="store_true", help="skip the figures")
    parser.add_argument("--quiet", action="store_true", help="no progress messages")
    args = parser.parse_args(argv)

    def fail(message: str) -> int:
        print(f"calibrate: {message}", file=sys.stderr)
        return 2

    bag = Path(args.bag)
    if not bag.exists():
        return fail(f"bag not found: {bag}")
    if args.max_starts < 1:
        return fail("--max-starts must be at least 1")
    # Loaded only now, after the thread limits above, so that `--help` and a bad argument answer at once.
    try:
        from foos_bag import BagError, read_ball_detections, topics  # the bag reader and numpy: half a second
    except ImportError as error:
        return fail(f"foos_bag is not importable ({error}); source scripts/env.sh")
    from .game_data import read_game  # loaded with the pipeline, after the thread limits
    from .pipeline import DataError, Options, calibrate, plain_summary  # scipy, MuJoCo, matplotlib: seconds
    from .rods import RodDataError  # likewise

    progress = (lambda message: None) if args.quiet else (lambda message: print(f"[calibrate] {message}", file=sys.stderr, flush=True))
    try:
        # Everything is read and checked before anything is written. A bag with neither the ball nor the
        # drives' commands is refused for the ball it lacks; one with commands but no ball (a drives-only
        # recording) has its rods calibrated and the ball skipped.
        present = topics(bag)
        has_commands = any(command_topic(team) in present for team in TEAMS)
        detections = read_ball_detections(bag, args.topic) if args.topic in present or not has_commands else None
        encoders, drives = read_game(bag)  # a game's joint states and commands
        report = calibrate(detections.t if detections else None, detections.position if detections else None,
                           detections.frame_id if detections else "table", Path(args.out),
                           Options(args.max_starts, args.seed, not args.no_figures, base=args.base), progress, str(bag),
                           drives=drives, encoders=encoders)
    except (BagError, DataError, ParamsError, RodDataError) as error:
        return fail(str(error).splitlines()[0])
    except OSError as error:
        return fail(f"{error.strerror or error}: {error.filename or ''}".strip())
    except KeyboardInterrupt:
        return fail("interrupted")
    print(plain_summary(report))
    print(f"Report: {Path(args.out) / 'report.md'} (and report.json, figures) - {report['runtime_s']:.0f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
