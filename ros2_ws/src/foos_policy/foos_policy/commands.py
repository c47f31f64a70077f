"""What the offline commands (train, evaluate, evaluate_bag) share: the task options, how they fail and
the JSON they write."""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Callable, TypeVar

from .tasks import OPPONENTS, RESETS

T = TypeVar("T")


def add_task_arguments(parser: argparse.ArgumentParser) -> None:
    """--reset, --opponent, --opponent-policy, --opponent-delay, --params-file and the views: the task a policy is
    trained or evaluated on."""
    parser.add_argument("--reset", choices=RESETS, default="paper",
                        help="paper: the paper's centre serve; hardened: a nearly still ball in front of a home rod; resting: the "
                             "same ball at rest (a curriculum's first stage) (default paper)")
    parser.add_argument("--opponent", choices=OPPONENTS, default="none",
                        help="none: passive away rods; scripted: tracking goalie+defence; selfplay: a frozen policy; "
                             "lifted: every away rod horizontal (default none)")
    parser.add_argument("--opponent-policy", default=None,
                        help="PATH.zip or shipped name of the frozen away policy for --opponent selfplay")
    parser.add_argument("--opponent-delay", type=float, default=0.0, metavar="SECONDS",
                        help="the away team acts on what it saw this long ago, rounded to 20 ms control steps: a real "
                             "table's camera and drive dead time (default 0: the scripted opponent reacts at once)")
    parser.add_argument("--params-file", default=None,
                        help="the table to play on (default the nominal table on the fast physics): e.g. foos_core's "
                             "params/robot_table.yaml (a robot table's jerk-limited drives), params/reference_table.yaml "
                             "(the 20 kHz reference) or a calibrate run's calibrated_table.yaml, to measure how a policy transfers")
    parser.add_argument("--view", choices=("camera", "instant"), default="camera",
                        help="how the home policy sees the ball: camera: as a real table's camera loop delivers it, 40 ms "
                             "late with 1.5 mm of noise (foos_policy.camera_view); instant: the true state at once "
                             "(how the policies before 27 Nov were trained) (default camera)")
    parser.add_argument("--opponent-view", choices=("camera", "instant"), default="camera",
                        help="the same for the away team; instant: the scripted opponent of old, reacting at once to "
                             "the true state (default camera)")


def check_task_arguments(parser: argparse.ArgumentParser, args: argparse.Namespace) -> None:
    if args.opponent == "selfplay" and not args.opponent_policy:
        parser.error("--opponent selfplay needs --opponent-policy PATH.zip")
    if not args.opponent_delay >= 0:
        parser.error("--opponent-delay must be at least 0 seconds")


def run_command(prog: str, work: Callable[[], T], errors: tuple[type[Exception], ...],
                interrupted: str = "interrupted", out: str | Path | None = None) -> T:
    """work()'s result, also written to `out` as JSON when given. An error of the `errors` kinds is one line
    on stderr and exit code 1 (the user's input was wrong, no traceback); Ctrl-C says `interrupted` and
    exits with 130."""
    try:
        result = work()
    except errors as exc:
        print(f"{prog}: {exc}".splitlines()[0], file=sys.stderr)
        raise SystemExit(1) from None
    except KeyboardInterrupt:
        print(f"{prog}: {interrupted}", file=sys.stderr)
        raise SystemExit(130) from None
    if out:
        write_json(out, result)
    return result


def write_json(path: str | Path, data: dict) -> None:
    Path(path).write_text(json.dumps(data, indent=2) + "\n")
