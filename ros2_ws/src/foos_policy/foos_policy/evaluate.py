"""`ros2 run foos_policy evaluate`: a policy on a fixed seed set, summarized with confidence intervals."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .commands import add_task_arguments, check_task_arguments, run_command
from .env import make_env
from .evaluation import episode_seeds, run_episodes, summarize
from .policies import PolicyError, make_policy, shipped_policies

DESCRIPTION = """\
Evaluate a policy for the home team in-process on a fixed set of episode seeds and write a JSON summary.

--policy is one of
  zero       all rods held still (the paper's serve alone)
  random     uniform random actions in [-20, 20]
  scripted   the hand-written tracking-and-kicking controller
  NAME       a shipped policy, e.g. sac_hardened_scripted_s0 (see --list)
  PATH.zip   a model saved by `train`

The summary holds win_rate, own_goal_rate, mean_length (steps of 20 ms), touches (home rod-ball touches
per episode), goals_after_touch, goals_without_touch and no_touch_goal_share = the share of home goals
scored with no home touch at all (the serve's inflation), each with a 95 % interval (Wilson for rates,
normal for means). Episodes use seeds SEED*100003 + i, so two policies with the same --seed and
--episodes see the same serves.

Example:
  ros2 run foos_policy evaluate --policy zero --reset paper --opponent none --episodes 200 --seed 0 --out zero_paper.json
"""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="evaluate", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--policy", help="zero | random | scripted | shipped NAME | PATH.zip")
    add_task_arguments(p)
    p.add_argument("--episodes", type=int, default=100, help="number of episodes (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the episode set (default 0)")
    p.add_argument("--out", default=None, help="JSON file to write (default: print only)")
    p.add_argument("--list", action="store_true", help="list the shipped policies and exit")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    args = p.parse_args(argv)
    if not args.list and not args.policy:
        p.error("--policy is required (zero, random, scripted, a shipped name or PATH.zip)")
    if args.episodes <= 0:
        p.error("--episodes must be positive")
    check_task_arguments(p, args)
    return args


def evaluate(args) -> dict:
    env = make_env(args.reset, args.opponent, args.opponent_policy, params_file=args.params_file, opponent_delay=args.opponent_delay,
                   view=args.view, opponent_view=args.opponent_view)
    policy = make_policy(args.policy, env.sim.params, env.sim.command_limits, seed=args.seed)
    start = time.time()
    results = run_episodes(env, policy.predict, episode_seeds(args.seed, args.episodes), progress=not args.no_progress,
                           desc=f"{policy.name} {args.reset}/{args.opponent}")
    wall = time.time() - start
    return summarize(results, extra={
        "policy": args.policy, "reset": args.reset, "opponent": args.opponent, "seed": args.seed,
        "opponent_delay_s": env.opponent_delay_steps * env.dt, "view": args.view, "opponent_view": args.opponent_view,
        "camera_latency_s": env.config.camera_latency, "camera_noise_m": env.config.camera_noise,
        "params_file": args.params_file, "physics": env.sim.physics,
        "control_rate_hz": 1.0 / env.dt, "max_steps": env.config.max_steps, "wall_s": round(wall, 1),
        "command": "evaluate " + " ".join(sys.argv[1:]),
    })


def main(argv=None) -> int:
    args = parse_args(argv)
    if args.list:
        print("\n".join(shipped_policies()) or "no shipped policies")
        return 0
    if args.out:
        out = Path(args.out)
        if out.parent and not out.parent.exists():
            print(f"evaluate: directory {out.parent} does not exist", file=sys.stderr)
            return 1
    summary = run_command("evaluate", lambda: evaluate(args), (PolicyError, ValueError, OSError), out=args.out)
    share = summary["no_touch_goal_share"]
    print(f"{args.policy} {args.reset}/{args.opponent}: win {summary['win_rate']:.3f} "
          f"[{summary['win_rate_ci95'][0]:.3f}, {summary['win_rate_ci95'][1]:.3f}]  own goal {summary['own_goal_rate']:.3f}  "
          f"length {summary['mean_length']:.1f}  touches {summary['touches']:.2f}  "
          f"no-touch goal share {'n/a' if share is None else f'{share:.3f}'}  ({summary['episodes']} episodes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
