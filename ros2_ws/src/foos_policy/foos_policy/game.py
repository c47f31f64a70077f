"""Game statistics from sampled states, shared by evaluate_bag and the in-process game (ROS-free).

A recording has no contact data, so a touch is inferred the same way for both: the ball centre is
within reach of a figure (its foot and body, at the rod's recorded slide and rotation) and the ball's
velocity jumps by more than TOUCH_DV between neighbouring samples. Per team it reports goals, touches,
possession (share of in-play time since the team's last touch) and shot speeds (the ball's highest
planar speed in the SHOT_WINDOW after a touch that sends it toward the opponent's goal).

`play_game` runs the very loop sim_node runs (foos_sim.sim_runner.SimRunner: random serves, 100 Hz
samples, goals, watchdog) with a policy commanding at 50 Hz, so its numbers are the in-process twin
of a recorded sim_node + policy_node game.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from tqdm import tqdm

from foos_core.joints import joint_order
from foos_core.names import JOINT_NAMES, RODS, TEAMS, rod_name, team_joint_names
from foos_sim.sim_runner import Goal, RunnerConfig, SimRunner, StateSample
from foos_sim.simulation import TableSimulation

from .evaluation import wilson_interval
from .observation import action_to_command, observe, other_team

TOUCH_DV = 0.25      # m/s, velocity jump between samples that marks a hit
TOUCH_MARGIN = 0.012  # m, slack around a figure (the ball moves up to ~5 cm between 100 Hz samples at speed)
SHOT_WINDOW = 0.1    # s after a touch in which the shot speed is measured


@dataclass(frozen=True)
class Figure:
    team: int       # 0 home, 1 away
    rod_y: float
    x0: float       # x at slide 0
    slide: int      # joint index in JOINT_NAMES
    rotate: int


def figures_of(params: dict) -> list[Figure]:
    layout = params["rods"]["layout"]
    figures = []
    for ti, team in enumerate(TEAMS):
        # the team's joints in command order: each rod's slide, then its rotation
        joints = joint_order(JOINT_NAMES, team_joint_names(team)).reshape(len(RODS), 2)
        for rod, (slide, rotate) in zip(RODS, joints):
            r = layout[rod_name(team, rod)]
            n = int(r["figures"])
            for i in range(n):
                figures.append(Figure(ti, float(r["y"]), (i - (n - 1) / 2) * float(r["spacing"]), int(slide), int(rotate)))
    return figures


def near_figures(params: dict, ball_position: np.ndarray, joint_positions: np.ndarray) -> np.ndarray:
    """(N, 2) booleans: the ball within reach of a home / away figure at each sample."""
    fig = params["figure"]
    axis_h = float(params["rods"]["axis_height"])
    radius = float(params["ball"]["radius"])
    foot_x, foot_y, _ = (float(v) for v in fig["foot_size"])
    reach = axis_h - float(fig["foot_clearance"])  # rod axis to the foot's sole
    near = np.zeros((len(ball_position), 2), dtype=bool)
    bx, by, bz = ball_position[:, 0], ball_position[:, 1], ball_position[:, 2]
    for f in figures_of(params):
        fx = f.x0 + joint_positions[:, f.slide]
        angle = joint_positions[:, f.rotate]
        # the figure as a segment from the rod axis to its sole, swung about +x (+ swings the foot to +y)
        dy, dz = np.sin(angle), -np.cos(angle)
        py, pz = by - f.rod_y, bz - axis_h
        s = np.clip(py * dy + pz * dz, 0.0, reach)
        dist = np.hypot(py - s * dy, pz - s * dz)
        hit = (np.abs(bx - fx) < foot_x / 2 + radius + TOUCH_MARGIN) & (dist < foot_y / 2 + radius + TOUCH_MARGIN)
        near[:, f.team] |= hit
    return near


def analyze_game(params: dict, t: np.ndarray, ball_position: np.ndarray, ball_velocity: np.ndarray,
                 joint_t: np.ndarray, joint_positions: np.ndarray, goal_teams: Sequence[str]) -> dict:
    """Goals, touches, possession and shot speeds of a game sampled at times t (ball) and joint_t."""
    t = np.asarray(t, float)
    if t.size < 3:
        raise ValueError("too little data: fewer than 3 ball states")
    if np.any(np.diff(t) < 0):
        raise ValueError("ball state timestamps go backwards")
    pos, vel = np.asarray(ball_position, float), np.asarray(ball_velocity, float)
    if not (np.all(np.isfinite(pos)) and np.all(np.isfinite(vel))):
        raise ValueError("ball states hold NaN or infinite values")
    # joints at the ball's sample times (nearest earlier joint sample)
    idx = np.clip(np.searchsorted(joint_t, t, side="right") - 1, 0, len(joint_t) - 1)
    q = np.asarray(joint_positions, float)[idx]
    near = near_figures(params, pos, q)
    dv = np.zeros(t.size)
    dv[1:-1] = np.linalg.norm(vel[2:, :2] - vel[:-2, :2], axis=1)
    touching = near & (dv[:, None] > TOUCH_DV)
    starts = touching & ~np.vstack([np.zeros((1, 2), bool), touching[:-1]])
    half_length = float(params["field"]["length"]) / 2
    in_play = np.abs(pos[:, 1]) <= half_length

    # possession: time after each team's last touch, in play only
    holder = np.full(t.size, -1)
    current = -1
    for k in range(t.size):
        if starts[k, 0] and not starts[k, 1]:
            current = 0
        elif starts[k, 1] and not starts[k, 0]:
            current = 1
        holder[k] = current
    dt = np.append(np.diff(t), 0.0)
    held = np.array([dt[(holder == team) & in_play].sum() for team in (0, 1)])

    shots: list[list[float]] = [[], []]
    for team, direction in ((0, 1.0), (1, -1.0)):
        for k in np.flatnonzero(starts[:, team]):
            window = (t > t[k]) & (t <= t[k] + SHOT_WINDOW + 1e-4)  # margin: bag stamps are rounded to ns
            if not window.any():
                continue
            speeds = np.hypot(vel[window, 0], vel[window, 1])
            j = np.argmax(speeds)
            if direction * vel[window][j, 1] > 0:
                shots[team].append(float(speeds[j]))

    goals = {team: sum(1 for g in goal_teams if g == team) for team in TEAMS}
    total = goals["home"] + goals["away"]
    duration = float(t[-1] - t[0])
    result = {
        "duration_s": duration,
        "goals_home": goals["home"], "goals_away": goals["away"],
        "home_goal_share": goals["home"] / total if total else None,
        "home_goal_share_ci95": list(wilson_interval(goals["home"], total)) if total else None,
        "goals_per_minute": 60.0 * total / duration if duration > 0 else None,
        "home_goals_per_minute": 60.0 * goals["home"] / duration if duration > 0 else None,
        "touches_home": int(starts[:, 0].sum()), "touches_away": int(starts[:, 1].sum()),
        "touches_home_per_minute": 60.0 * starts[:, 0].sum() / duration if duration > 0 else None,
        "possession_home": float(held[0] / held.sum()) if held.sum() > 0 else None,
        "shots_home": len(shots[0]), "shots_away": len(shots[1]),
        "shot_speed_home_mean": float(np.mean(shots[0])) if shots[0] else None,
        "shot_speed_home_max": float(np.max(shots[0])) if shots[0] else None,
        "shot_speed_away_mean": float(np.mean(shots[1])) if shots[1] else None,
        "shot_speed_away_max": float(np.max(shots[1])) if shots[1] else None,
    }
    return result


def pool_games(games: Sequence[dict]) -> dict:
    """Several games as one: their goals, touches and durations summed, the home share of goals and its
    interval recomputed. A reference pooled from several serves is steadier than a single game, whose
    touch count alone swings from 0 to 9 in 23 s with one policy."""
    duration = sum(g["duration_s"] for g in games)
    home = sum(g["goals_home"] for g in games)
    away = sum(g["goals_away"] for g in games)
    total = home + away
    return {
        "games": len(games), "duration_s": duration, "goals_home": home, "goals_away": away,
        "home_goal_share": home / total if total else None,
        "home_goal_share_ci95": list(wilson_interval(home, total)) if total else None,
        "touches_home": sum(g["touches_home"] for g in games), "touches_away": sum(g["touches_away"] for g in games),
    }


def dispersion(counts: Sequence[float], durations: Sequence[float]) -> float:
    """How much more the games' counts spread than Poisson counts would (Pearson chi-square over its degrees of
    freedom, at least 1): 1 for one game or a Poisson process."""
    c, t = np.asarray(counts, dtype=float), np.asarray(durations, dtype=float)
    if c.size < 2 or c.sum() == 0:
        return 1.0
    expected = c.sum() * t / t.sum()
    return max(1.0, float(np.sum((c - expected) ** 2 / expected) / (c.size - 1)))


def _rate_test(count_a: int, count_b: int, time_a: float, time_b: float, overdispersion: float = 1.0) -> float:
    """Two-sided p-value that two counts over times a and b share one rate: the conditional binomial test of Poisson
    counts, or where the reference games spread `overdispersion` times more than Poisson counts, its normal
    approximation with the variance scaled by that factor (quasi-Poisson)."""
    # here: scipy.stats takes most of a second to import, and only --compare-policy needs it
    from scipy import stats

    n = count_a + count_b
    if n == 0:
        return 1.0
    share = time_a / (time_a + time_b)
    if overdispersion <= 1.0:
        return float(stats.binomtest(count_a, n, share).pvalue)
    z = (count_a - n * share) / np.sqrt(overdispersion * n * share * (1.0 - share))
    return float(2.0 * stats.norm.sf(abs(z)))


def compare_games(a: dict, b: dict, alpha: float = 0.01) -> dict:
    """Whether two games agree: goals for and against and home touches per unit time (rate tests) and the home
    share of goals (their Wilson intervals overlap). Where b pools several games (`per_game`), their own spread
    sets each test's overdispersion: on the robot table four 300 s games of one policy scored 13 to 38 goals, six
    times the spread of Poisson counts, and a Poisson test would call a fifth game from the same loop different."""
    ta, tb = a["duration_s"], b["duration_s"]
    games = b.get("per_game") or []
    durations = [g["duration_s"] for g in games]
    spread = {key: dispersion([g[key] for g in games], durations) for key in ("goals_home", "goals_away", "touches_home")}
    goals_p = _rate_test(a["goals_home"], b["goals_home"], ta, tb, spread["goals_home"])
    against_p = _rate_test(a["goals_away"], b["goals_away"], ta, tb, spread["goals_away"])
    touches_p = _rate_test(a["touches_home"], b["touches_home"], ta, tb, spread["touches_home"])
    ci_a, ci_b = a.get("home_goal_share_ci95"), b.get("home_goal_share_ci95")
    share_overlap = True if not (ci_a and ci_b) else (ci_a[0] <= ci_b[1] and ci_b[0] <= ci_a[1])
    return {
        "home_goals_a": a["goals_home"], "home_goals_b": b["goals_home"],
        "away_goals_a": a["goals_away"], "away_goals_b": b["goals_away"],
        "home_touches_a": a["touches_home"], "home_touches_b": b["touches_home"],
        "duration_a_s": ta, "duration_b_s": tb,
        "overdispersion": spread,
        "home_goals_p_value": goals_p, "away_goals_p_value": against_p, "home_touches_p_value": touches_p,
        "poisson_p_values": {"home_goals": _rate_test(a["goals_home"], b["goals_home"], ta, tb),
                             "away_goals": _rate_test(a["goals_away"], b["goals_away"], ta, tb),
                             "home_touches": _rate_test(a["touches_home"], b["touches_home"], ta, tb)},
        "home_share_ci_overlap": share_overlap,
        "consistent": goals_p > alpha and against_p > alpha and touches_p > alpha and share_overlap,
    }


def play_game(policy, seconds: float, seed: int = 0, team: str = "home", opponent=None, control_rate: float = 50.0,
              params_file: Optional[str] = None, progress: bool = False) -> dict:
    """A game as sim_node plays it (random serves, 100 Hz samples), with `policy` on `team` and an
    optional `opponent` policy on the other team; returns analyze_game's statistics."""
    samples = play_game_samples(policy, seconds, seed, team, opponent, control_rate, params_file, progress)
    return analyze_game(samples["params"], samples["t"], samples["ball_position"], samples["ball_velocity"],
                        samples["t"], samples["joint_positions"], samples["goals"])


def play_game_samples(policy, seconds: float, seed: int = 0, team: str = "home", opponent=None,
                      control_rate: float = 50.0, params_file: Optional[str] = None, progress: bool = False) -> dict:
    """The raw 100 Hz samples of an in-process game: t, ball_position, ball_velocity, joint_positions,
    joint_velocities, goals (scoring teams), goal_times and the table params."""
    sim = TableSimulation(params_file)
    runner = SimRunner(sim, RunnerConfig(serve="random", seed=seed, publish_rate=100.0))
    period = 1.0 / control_rate
    next_tick = runner.time
    latest: Optional[StateSample] = None
    ts, pos, vel, qs, dqs, goals, goal_times = [], [], [], [], [], [], []
    bar = tqdm(total=int(seconds), unit="sim s", disable=not progress)
    while runner.time < seconds:
        for event in runner.advance():
            if isinstance(event, StateSample):
                latest = event
                ts.append(event.time)
                pos.append(event.ball_position)
                vel.append(event.ball_velocity)
                qs.append(event.joint_positions)
                dqs.append(event.joint_velocities)
                if len(ts) % 100 == 0:
                    bar.update(int(event.time) - bar.n)
            elif isinstance(event, Goal):
                goals.append(event.team)
                goal_times.append(event.time)
        if latest is not None and runner.time + 1e-9 >= next_tick:
            next_tick += period
            for who, pol in ((team, policy), (other_team(team), opponent)):
                if pol is None:
                    continue
                obs = observe(who, latest.ball_position, latest.ball_velocity, latest.joint_positions, latest.joint_velocities)
                runner.command(who, action_to_command(who, pol.predict(obs), sim.command_limits))
    bar.close()
    return {"t": np.array(ts), "ball_position": np.array(pos), "ball_velocity": np.array(vel),
            "joint_positions": np.array(qs), "joint_velocities": np.array(dqs), "goals": goals,
            "goal_times": np.array(goal_times), "params": sim.params}


def finite_or_none(x) -> Optional[float]:
    return None if x is None or not math.isfinite(x) else float(x)
