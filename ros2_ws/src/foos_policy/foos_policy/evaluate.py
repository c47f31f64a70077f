"""`ros2 run foos_policy evaluate`: a policy on a fixed seed set, summarized with confidence intervals."""
from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

from .commands import add_task_arguments, check_task_arguments, run_command
from .env import make_env
from .evaluation import episode_seeds, paired_difference, run_episodes, summarize
from .policies import PolicyError, make_policy, shipped_policies

DESCRIPTION = """\
Evaluate a policy for the home team in-process on a fixed set of episode seeds and write a JSON summary.

--policy is one of
  zero       all rods held still (the paper's serve alone)
  random     uniform random actions in [-20, 20]
  scripted   the hand-written tracking-and-kicking controller
  lift-ahead the same, its rods ahead of the ball raised back, held on the braking curve (the residual base)
  NAME       a shipped policy, e.g. sac_hardened_scripted_s0 (see --list)
  PATH.zip   a model saved by `train`

The summary holds win_rate, own_goal_rate, mean_length (steps of 20 ms), touches (home rod-ball touches
per episode), goals_after_touch, goals_without_touch and no_touch_goal_share = the share of home goals
scored with no home touch at all (the serve's inflation), each with a 95 % interval (Wilson for rates,
normal for means); own_goals_by_last_touch splits the own goals (goals against) by the team that touched
the ball last (home: off the policy's own rods, then own_goals_by_home_rod says which; away: the opponent's
shot or clearance; none: untouched since the serve). spun_touch_share is the share of home touches made by a
rod that had turned more than 360 degrees one way (a spin: illegal in tournament play, foos_policy.spins),
own_goals_off_spins / goals_off_spins the goals against / for whose last home touch was one,
win_rate_without_spins the win rate with those goals disallowed, and home_turns the home rods' full turns an
episode. Episodes use seeds SEED*100003 + i, so two policies with the same --seed and
--episodes see the same serves.

--transfer-to FILE... plays the same episodes on other tables and prints, for each, the paired change of
the win and own-goal rates with a 95 % bootstrap interval over the episodes (the JSON's `transfer`).

Examples:
  ros2 run foos_policy evaluate --policy zero --reset paper --opponent none --episodes 200 --seed 0 --out zero_paper.json
"""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="evaluate", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--policy", help="zero | random | scripted | lift-ahead | shipped NAME | PATH.zip")
    add_task_arguments(p)
    p.add_argument("--transfer-to", nargs="+", default=[], metavar="PARAMS_FILE",
                   help="also play the same episodes (seeds) on these tables, e.g. the 20 kHz reference "
                        "(params/robot_reference_table.yaml) or a calibrated table, and report how the win and own-goal "
                        "rates change from --params-file's: the paired difference with a 95 %% bootstrap interval over "
                        "the episodes")
    p.add_argument("--episodes", type=int, default=100, help="number of episodes (default 100)")
    p.add_argument("--seed", type=int, default=0, help="seed of the episode set (default 0)")
    p.add_argument("--out", default=None, help="JSON file to write (default: print only)")
    p.add_argument("--list", action="store_true", help="list the shipped policies and exit")
    p.add_argument("--no-progress", action="store_true", help="hide the progress bar")
    args = p.parse_args(argv)
    if not args.list and not args.policy:
        p.error("--policy is required (zero, random, scripted, lift-ahead, a shipped name or PATH.zip)")
    if args.episodes <= 0:
        p.error("--episodes must be positive")
    check_task_arguments(p, args)
    return args


def play(args, params_file, seeds: list[int]) -> tuple[list[dict], dict]:
    """The episodes of `seeds` on the table `params_file`, and what the summary says of the set-up."""
    env = make_env(args.reset, args.opponent, args.opponent_policy, params_file=params_file, opponent_delay=args.opponent_delay,
                   view=args.view, opponent_view=args.opponent_view)
    policy = make_policy(args.policy, env.sim.params, env.sim.command_limits, seed=args.seed)
    start = time.time()
    results = run_episodes(env, policy.predict, seeds, progress=not args.no_progress,
                           desc=f"{policy.name} {args.reset}/{args.opponent} {Path(params_file).stem if params_file else 'nominal'}",
                           new_episode=policy.reset)
    return results, {"params_file": params_file, "physics": env.sim.physics, "wall_s": round(time.time() - start, 1),
                     "opponent_delay_s": env.opponent_delay_steps * env.dt, "camera_latency_s": env.config.camera_latency,
                     "camera_noise_m": env.config.camera_noise, "control_rate_hz": 1.0 / env.dt, "max_steps": env.config.max_steps}


def transfer_row(base: list[dict], results: list[dict], setup: dict) -> dict:
    """One other table's rates, and their paired differences from the base table's on the same episodes."""
    summary = summarize(results)
    row = {key: summary[key] for key in ("win_rate", "win_rate_ci95", "own_goal_rate", "own_goal_rate_ci95", "touches")}
    for rate, key in (("win", "win"), ("own_goal", "lose")):
        mean, low, high = paired_difference([r[key] for r in base], [r[key] for r in results])
        row[f"{rate}_difference"] = mean
        row[f"{rate}_difference_ci95"] = [low, high]
    return {**setup, **row}


def evaluate(args) -> dict:
    seeds = episode_seeds(args.seed, args.episodes)
    results, setup = play(args, args.params_file, seeds)
    transfer = [transfer_row(results, *play(args, other, seeds)) for other in args.transfer_to]
    summary = summarize(results, extra={
        "policy": args.policy, "reset": args.reset, "opponent": args.opponent, "seed": args.seed,
        "view": args.view, "opponent_view": args.opponent_view, **setup,
        "command": "evaluate " + " ".join(sys.argv[1:]),
    })
    if transfer:
        summary["transfer"] = transfer
    return summary


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
    if summary["own_goal_rate"] and "own_goals_by_last_touch" in summary:
        by_touch = ", ".join(f"{who} {rate:.2f}" for who, rate in summary["own_goals_by_last_touch"].items() if rate)
        by_rod = ", ".join(f"{rod} {rate:.2f}" for rod, rate in summary["own_goals_by_home_rod"].items())
        print(f"  own goals by the last touch: {by_touch}" + (f" (home rods: {by_rod})" if by_rod else ""))
    if summary.get("home_turns") is not None:
        share = summary["spun_touch_share"]
        print(f"  spins (a rod turned over 360 degrees one way before the touch; illegal in tournament play): "
              f"{'n/a' if share is None else f'{share:.0%}'} of home touches; goals off spins {summary['goals_off_spins']:.2f} (the win "
              f"rate without them {summary['win_rate_without_spins']:.2f}), own goals off spins {summary['own_goals_off_spins']:.2f}; "
              f"the home rods turn {summary['home_turns']:.1f} turns an episode")
    for row in summary.get("transfer", []):
        dw, dl = row["win_difference_ci95"], row["own_goal_difference_ci95"]
        print(f"  on {row['params_file']} ({row['physics']}): win {row['win_rate']:.3f}, change {row['win_difference']:+.3f} "
              f"[{dw[0]:+.3f}, {dw[1]:+.3f}]; own goal {row['own_goal_rate']:.3f}, change {row['own_goal_difference']:+.3f} "
              f"[{dl[0]:+.3f}, {dl[1]:+.3f}] (paired, same episodes)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
