"""`ros2 run foos_policy evaluate_bag BAG`: game statistics from a recorded game."""
from __future__ import annotations

import argparse
import sys
from pathlib import Path

from foos_bag import BagError, read_ball_states, read_goals, read_joint_states, topics
from foos_core.joints import joint_order, take_joints
from foos_core.names import BALL_STATE_TOPIC, GOAL_TOPIC, SIM_BALL_STATE_TOPIC, TEAMS
from foos_core.table_params import load_params
from foos_sim import command_limits

from .commands import run_command
from .controller import missing_joints
from .game import analyze_game, compare_games, play_game, pool_games
from .policies import PolicyError, make_policy

DESCRIPTION = """\
Compute a recorded game's statistics from a rosbag2 bag holding /ball/state, /joint_states and /sim/goal
(as recorded from sim_node + policy_node; where the bag holds /sim/ball/state, sim_node's true ball while its
camera fed tracker_node, that is the ball the game is judged on): goals per team, the home share of goals with a 95 % Wilson
interval, goals per minute, rod-ball touches per team, possession and shot speeds.

Touches are inferred (a bag has no contact data): the ball within reach of a figure at its recorded slide
and rotation while its velocity jumps by more than 0.25 m/s between samples. Shot speed: the ball's
highest planar speed within 0.1 s after a touch that sends it toward the opponent's goal.

--compare-policy runs the same game in-process (sim_node's own loop: random serves, 100 Hz samples) for
the bag's duration with that policy on --team, and tests whether the home goal rates agree.

Examples:
  ros2 run foos_policy evaluate_bag game_bag
  ros2 run foos_policy evaluate_bag game_bag --out stats.json --compare-policy sac_hardened_scripted_s0 --seed 0
  ros2 run foos_policy evaluate_bag game_bag --compare-policy sac_hardened_scripted_s0 --compare-opponent scripted
"""


def parse_args(argv=None) -> argparse.Namespace:
    p = argparse.ArgumentParser(prog="evaluate_bag", description=DESCRIPTION, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", help="bag directory (MCAP or sqlite3)")
    p.add_argument("--out", default=None, help="JSON file to write (default: print only)")
    p.add_argument("--params-file", default=None, help="table parameter file of the recorded table (default nominal)")
    p.add_argument("--compare-policy", default=None, help="also play this policy in-process for the same duration and compare")
    p.add_argument("--team", choices=TEAMS, default="home", help="team of --compare-policy (default home)")
    p.add_argument("--compare-opponent", default=None,
                   help="the policy of the other team in the in-process game, as its policy_node played in the bag "
                        "(e.g. scripted; default: that team's rods stand still)")
    p.add_argument("--seed", type=int, default=0, help="serve seed of the first in-process game (default 0)")
    p.add_argument("--compare-games", type=int, default=4,
                   help="in-process games of the bag's duration, serve seeds SEED, SEED+1, ..., pooled into the "
                        "reference the bag is compared with (default 4: one short game is too noisy a reference)")
    return p.parse_args(argv)


def evaluate_bag(args) -> dict:
    path = Path(args.bag)
    if not path.exists():
        raise FileNotFoundError(f"no bag at {path}")
    params = load_params(args.params_file)
    recorded = topics(path)
    # With the simulated camera on, /ball/state is what tracker_node made of the images, and sim_node's true ball
    # is /sim/ball/state: a game is judged on what happened, so the truth is read where the bag has it.
    ball_topic = SIM_BALL_STATE_TOPIC if SIM_BALL_STATE_TOPIC in recorded else BALL_STATE_TOPIC
    balls = read_ball_states(path, ball_topic)
    joints = read_joint_states(path)
    order = joint_order(joints.names, allow_missing=True)
    missing = missing_joints(order)
    if missing:
        raise ValueError(f"{path}: /joint_states lacks {len(missing)} rod joints (e.g. {missing[0]})")
    q = take_joints(joints.position, order)
    has_goals = GOAL_TOPIC in recorded
    goal_teams = read_goals(path)[1] if has_goals else []  # read_goals gives (stamps, teams)
    bad = [g for g in goal_teams if g not in TEAMS]
    if bad:
        raise ValueError(f"{path}: {GOAL_TOPIC} holds `{bad[0]}`, expected home or away")
    stats = analyze_game(params, balls.t, balls.position, balls.velocity, joints.t, q, goal_teams)
    stats["bag"] = str(path)
    stats["goal_topic"] = has_goals
    stats["ball_topic"] = ball_topic
    if args.compare_policy:
        if args.compare_games < 1:
            raise ValueError(f"--compare-games must be at least 1, got {args.compare_games}")
        limits = command_limits(params)
        games = []
        for seed in range(args.seed, args.seed + args.compare_games):
            # fresh policies per game: a policy may keep state (a filter, a latency queue) across steps
            policy = make_policy(args.compare_policy, params, limits, seed=seed)
            opponent = make_policy(args.compare_opponent, params, limits, seed=seed + 1) if args.compare_opponent else None
            games.append(play_game(policy, stats["duration_s"], seed=seed, team=args.team, opponent=opponent,
                                   params_file=args.params_file))
        in_process = pool_games(games)
        in_process["per_game"] = games  # their spread sets the comparison's overdispersion
        stats["in_process"] = in_process
        stats["comparison"] = compare_games(stats, in_process)
    return stats


def main(argv=None) -> int:
    args = parse_args(argv)
    stats = run_command("evaluate_bag", lambda: evaluate_bag(args), (BagError, PolicyError, ValueError, OSError), out=args.out)
    share = stats["home_goal_share"]
    print(f"{stats['duration_s']:.1f} s: goals home {stats['goals_home']} - away {stats['goals_away']}"
          f" (home share {'n/a' if share is None else f'{share:.2f}'}), touches home {stats['touches_home']} away {stats['touches_away']},"
          f" possession home {stats['possession_home'] if stats['possession_home'] is None else round(stats['possession_home'], 2)},"
          f" shots home {stats['shots_home']} (mean {stats['shot_speed_home_mean'] or 0:.2f} m/s)")
    if "comparison" in stats:
        c = stats["comparison"]
        print(f"in-process ({stats['in_process']['games']} games) {c['duration_b_s']:.1f} s: "
              f"goals home {c['home_goals_b']} - away {c['away_goals_b']}, touches home "
              f"{c['home_touches_b']} (bag: {c['home_goals_a']} - {c['away_goals_a']}, {c['home_touches_a']}); p goals "
              f"{c['home_goals_p_value']:.3f}, p goals against {c['away_goals_p_value']:.3f}, p touches {c['home_touches_p_value']:.3f} "
              f"(the in-process games spread {c['overdispersion']['goals_home']:.1f}, {c['overdispersion']['goals_away']:.1f} and "
              f"{c['overdispersion']['touches_home']:.1f} times Poisson counts): "
              f"{'consistent' if c['consistent'] else 'NOT consistent'}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
