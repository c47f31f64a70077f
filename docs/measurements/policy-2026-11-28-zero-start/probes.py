"""The probes of policy-2026-11-28-zero-start.md, on the residual action map (robot table, hardened reset, scripted
opponent, camera loop, the 100 episodes of seed 7):

    python probes.py constant     # fixed corrections: does any one vector move the win rate?
    python probes.py lift         # a rule: lift the own rods that stand between the ball and the away goal
    python probes.py stagnant [BASE]  # zero corrections (on the residual base BASE, default scripted): where the
                                      # stagnant episodes leave the ball
    python probes.py drift DIR    # the deterministic corrections' size in DIR/checkpoints over training

Run in a shell that sourced scripts/env.sh.
"""
import glob
import sys
import time
from collections import Counter

import numpy as np

from foos_core.names import RODS
from foos_core.table_params import ROBOT_PARAMS_FILE
from foos_policy.actions import RESIDUAL_ACTION_HIGH
from foos_policy.env import make_env
from foos_policy.evaluation import episode_seeds, run_episodes, summarize
from foos_policy.observation import scaled_observation
from foos_policy.policies import make_policy
from foos_policy.scripted import own_rod_geometry

SEEDS = episode_seeds(7, 100)


def residual_env(base: str = "scripted"):
    return make_env("hardened", "scripted", None, params_file=str(ROBOT_PARAMS_FILE), action="residual", residual_base=base)


def report(name: str, act, env) -> None:
    start = time.time()
    s = summarize(run_episodes(env, act, SEEDS))
    print(f"{name:30s} win {s['win_rate']:.2f} legal {s['win_rate_without_spins']:.2f} own {s['own_goal_rate']:.2f} "
          f"stagnant {s['stagnant_rate']:.2f} touches {s['touches']:.1f} length {s['mean_length']:.0f} "
          f"({time.time() - start:.0f} s)", flush=True)


def constant() -> None:
    env = residual_env()
    probes = {  # [slide, angle] per rod in RODS order: goalie, defence, midfield, attack
        "zero": np.zeros(8),
        "attack slide +20 mm": np.array([0, 0, 0, 0, 0, 0, 0.02, 0]),
        "attack slide -20 mm": np.array([0, 0, 0, 0, 0, 0, -0.02, 0]),
        "all slides +20 mm": np.tile([0.02, 0], 4),
        "all slides +35 mm": np.tile([0.035, 0], 4),
        "all angles +0.5": np.tile([0, 0.5], 4),
        "all angles -0.5": np.tile([0, -0.5], 4),
        "all angles +1.2": np.tile([0, 1.2], 4),
        "all angles -1.2": np.tile([0, -1.2], 4),
    }
    for name, action in probes.items():
        fixed = action.astype(np.float32)
        report(name, lambda obs, fixed=fixed: fixed, env)


def lift() -> None:
    env = residual_env()
    geometry = own_rod_geometry(env.sim.params)
    rod_y = np.array([geometry[rod].y for rod in RODS])

    def rule(margin: float, angle: float = 1.4, slide: float = 0.0):
        def act(obs):
            action = np.zeros(8, np.float32)
            action[1::2] = np.where(rod_y > obs[1] + margin, angle, 0.0)  # +y is toward the away goal
            action[0::2] = slide
            return action
        return act

    for name, act in [("lift ahead, margin 0", rule(0.0)), ("lift ahead, margin 0.04", rule(0.04)),
                      ("lift ahead, margin 0.10", rule(0.10)), ("lift ahead, margin 0.04, -1.4", rule(0.04, -1.4)),
                      ("lift ahead, margin 0.04, -20 mm", rule(0.04, 1.4, -0.02))]:
        report(name, act, env)


def stagnant(base: str = "scripted") -> None:
    env = residual_env(base)
    geometry = own_rod_geometry(env.sim.params)
    home_y = np.array([geometry[rod].y for rod in RODS])
    away_y = -home_y
    finals = []
    for seed in SEEDS:
        env.reset(seed=seed)
        while True:
            _, _, terminated, truncated, info = env.step(np.zeros(8, np.float32))
            if terminated or truncated:
                if info["episode_stats"].get("stagnant"):
                    finals.append(env.sim.ball_position()[:2].copy())
                break

    def zone(y: float) -> str:
        ahead_of_home, ahead_of_away = y - home_y, away_y - y
        if y < home_y[0]:
            return "behind the home goalie"
        if y > away_y[0]:
            return "behind the away goalie"
        if np.any((ahead_of_home > -0.02) & (ahead_of_home < 0.075)):
            return "in a home figure's reach (or under it)"
        reach = (ahead_of_away > -0.02) & (ahead_of_away < 0.075)
        if np.any(reach):
            rod = RODS[int(np.argmin(np.where(reach, ahead_of_away, np.inf)))]
            return f"in the away {rod}'s reach only" + (" (a lifted rod)" if rod in ("midfield", "attack") else "")
        return "in no figure's reach"

    print(len(finals), "stagnant episodes of", len(SEEDS))
    for where, count in Counter(zone(y) for _, y in finals).most_common():
        print(f"{count:3d}  {where}")


def drift(run_dir: str) -> None:
    env = make_env("hardened", "scripted", None, params_file=str(ROBOT_PARAMS_FILE))
    observations = []
    for seed in SEEDS[:5]:
        obs, _ = env.reset(seed=seed)
        for _ in range(150):
            observations.append(obs)
            obs, _, terminated, truncated, _ = env.step(np.zeros(8, np.float32))
            if terminated or truncated:
                break
    view = scaled_observation(np.array(observations))
    checkpoints = sorted(glob.glob(f"{run_dir}/checkpoints/*_steps.zip"), key=lambda p: int(p.split("_")[-2]))
    for path in checkpoints:
        model = make_policy(path, env.sim.params, env.sim.command_limits).model
        share = np.abs(model.predict(view, deterministic=True)[0]) / RESIDUAL_ACTION_HIGH
        print(f"{int(path.split('_')[-2]):7d} steps: median |correction| {np.median(share):.2f} of its bound, "
              f"{(share > 0.9).mean():.2f} above 0.9", flush=True)


if __name__ == "__main__":
    probe = sys.argv[1] if len(sys.argv) > 1 else ""
    if probe == "drift" and len(sys.argv) == 3:
        drift(sys.argv[2])
    elif probe == "stagnant" and len(sys.argv) == 3:
        stagnant(sys.argv[2])
    elif probe in ("constant", "lift", "stagnant"):
        globals()[probe]()
    else:
        sys.exit("usage: probes.py constant | lift | stagnant [BASE] | drift RUN_DIR")
