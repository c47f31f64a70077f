"""`ros2 run foos_policy shot_ceiling`: how often one aimed shot beats the scripted defence, by speed and by
the defence's reaction time, beside the kicks the home rods can actually make."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np

from .commands import run_command
from .shots import MOUTH_MARGIN, SHOT_LINE_AHEAD, kick_table, shot_outcomes

DESCRIPTION = f"""\
The ceiling of the hardened task against the scripted opponent, measured on the table's physics.

1. The kicks: the home attack rod's middle figure swings at full speed from hanging into a still ball
   {SHOT_LINE_AHEAD * 100:.1f} cm ahead of the rod, the ball sitting OFFSET across the foot's centre. Printed: the
   ball's speed and direction after the kick. A centred ball goes straight; the foot's corner sends it
   off at an angle, slower.
2. The shots: the ball held still in front of the home attack rod for 0.4 s while the scripted away goalie and
   defence settle on it (as they do in a hardened episode), then launched at SPEED toward a point drawn
   uniformly within +-{MOUTH_MARGIN * 100:.0f} cm of the goal's centre, the home outfield rods lifted out of its way.
   Printed: the share that scores and the share that rebounds into the home goal, with 95 % Wilson
   intervals. With --delays the scripted opponent acts on what it saw DELAY seconds earlier (a camera's
   and a drive's dead time; the scripted opponent of the task has none). With --carry-speeds the ball is
   first carried along the line at that speed for up to 0.2 s, as a figure pinning it would move it, the
   away rods following it, and shot from a random point of the carry.

No shot from a still ball that a policy kicks can beat the goal rate at its speed, so the carry-speed-0
rows bound what aiming alone wins; the carried rows show what moving the ball first buys.

Example:
  ros2 run foos_policy shot_ceiling --speeds 3,3.8,5,7 --delays 0,0.06,0.1 --shots 200 --out ceiling.json --figure ceiling.png
  ros2 run foos_policy shot_ceiling --speeds 3.8 --carry-speeds 0,1,2 --shots 200
"""


def float_list(text: str) -> list[float]:
    try:
        values = [float(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not a comma-separated list of numbers") from None
    if not values or not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"`{text}` is not a comma-separated list of numbers")
    return values


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="shot_ceiling", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--speeds", type=float_list, default=[3.0, 3.8, 5.0, 7.0], help="shot speeds in m/s (default 3,3.8,5,7)")
    p.add_argument("--delays", type=float_list, default=[0.0], help="opponent reaction delays in s, multiples of the 20 ms control step "
                                                                      "(default 0: the task's scripted opponent)")
    p.add_argument("--carry-speeds", type=float_list, default=[0.0],
                   help="speeds in m/s the ball is carried along the line at before the shot (default 0: shot from rest)")
    p.add_argument("--opponent-view", choices=("camera", "instant"), default="camera",
                   help="camera: the opponent sees the ball through a real table's camera loop (40 ms late, 1.5 mm of noise); "
                        "instant: the true ball at once, as the opponent of old (default camera)")
    p.add_argument("--shots", type=int, default=200, help="shots per speed and delay (default 200)")
    p.add_argument("--seed", type=int, default=0, help="seed of the shots (default 0)")
    p.add_argument("--params-file", default=None, help="the table (default the nominal table on the fast physics)")
    p.add_argument("--out", default=None, help="JSON file to write")
    p.add_argument("--figure", default=None, help="PNG of goal rate against shot speed, one line per delay")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bars")
    args = p.parse_args(argv)
    if args.shots <= 0:
        p.error("--shots must be positive")
    if any(s <= 0 for s in args.speeds):
        p.error("--speeds must be positive")
    if any(c < 0 for c in args.carry_speeds):
        p.error("--carry-speeds must not be negative")
    if any(d < 0 for d in args.delays):
        p.error("--delays must not be negative")
    for path in (args.out, args.figure):
        if path and not Path(path).resolve().parent.is_dir():
            p.error(f"directory {Path(path).parent} does not exist")
    return args


def measure(args) -> dict:
    offsets = [0.0, 0.015, 0.02, 0.0225, 0.025, 0.0275, 0.03]
    kicks = kick_table(offsets, params_file=args.params_file)
    rows = [shot_outcomes(speed, delay, args.shots, args.seed, carry, args.params_file, progress=not args.no_progress,
                          opponent_view=args.opponent_view)
            for delay in args.delays for carry in args.carry_speeds for speed in args.speeds]
    return {"kicks": [k.__dict__ for k in kicks], "shots": rows, "seed": args.seed, "params_file": args.params_file,
            "command": "shot_ceiling " + " ".join(sys.argv[1:])}


def plot(result: dict, path: str) -> None:
    """Goal rate against shot speed (one line per delay and carry speed); against the carry speed when only
    one shot speed was measured."""
    import matplotlib  # here: matplotlib takes most of a second to import, and only --figure needs it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # after use("Agg"): no display is needed

    rows = result["shots"]
    x_key = "speed" if len({r["speed"] for r in rows}) > 1 else "carry_speed"
    line_key = "carry_speed" if x_key == "speed" else "speed"
    fig, ax = plt.subplots(figsize=(6, 4))
    for delay, other in sorted({(r["delay_s"], r[line_key]) for r in rows}):
        line = [r for r in rows if (r["delay_s"], r[line_key]) == (delay, other)]
        x = [r[x_key] for r in line]
        rate = np.array([r["goal_rate"] for r in line])
        ci = np.array([r["goal_rate_ci95"] for r in line])
        label = f"reacting after {delay * 1e3:.0f} ms, " + (
            (f"ball carried at {other:g} m/s" if other else "ball at rest") if x_key == "speed" else f"shot at {other:g} m/s")
        ax.errorbar(x, rate, yerr=[rate - ci[:, 0], ci[:, 1] - rate], marker="o", capsize=3, label=label)
    if x_key == "speed":
        fastest = max(k["speed"] for k in result["kicks"])
        ax.axvline(fastest, color="0.5", linestyle="--", label=f"fastest kick of the rods ({fastest:.1f} m/s)")
        ax.set_xlabel("shot speed (m/s)")
    else:
        ax.set_xlabel("speed the ball is carried along the line at before the shot (m/s)")
    ax.set_ylabel("goal rate of one aimed shot")
    ax.set_ylim(0, 1)
    ax.set_xlim(left=0)
    ax.legend(loc="upper left", fontsize=7)
    ax.set_title("One aimed shot from the attack line against the scripted goalie and defence", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=120)
    plt.close(fig)


def main(argv=None) -> int:
    args = parse_args(argv)
    result = run_command("shot_ceiling", lambda: measure(args), (ValueError, OSError), out=args.out)
    print("kicks of the home attack rod (ball offset across the foot -> speed, direction):")
    for k in result["kicks"]:
        print(f"  {k['offset'] * 1e3:5.1f} mm  {k['speed']:4.2f} m/s  {k['angle']:+5.1f} deg")
    print("aimed shots against the settled scripted goalie and defence:")
    for r in result["shots"]:
        lo, hi = r["goal_rate_ci95"]
        carried = f"carried at {r['carry_speed']:g} m/s" if r["carry_speed"] else "from rest"
        print(f"  {r['speed']:4.1f} m/s {carried}, reacting after {r['delay_s'] * 1e3:3.0f} ms: "
              f"goal {r['goal_rate']:.2f} [{lo:.2f}, {hi:.2f}]  "
              f"own goal {r['own_goal_rate']:.2f}  ({r['shots']} shots)")
    if args.figure:
        plot(result, args.figure)
    return 0


if __name__ == "__main__":
    sys.exit(main())
