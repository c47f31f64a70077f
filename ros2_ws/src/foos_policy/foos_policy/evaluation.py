"""In-process evaluation on a fixed seed set, with confidence intervals (ROS-free)."""
from __future__ import annotations

import math
from typing import Callable, Optional

import numpy as np
from tqdm import tqdm

Z95 = 1.959963984540054


def wilson_interval(successes: float, n: int, z: float = Z95) -> tuple[float, float]:
    """95 % Wilson score interval of a binomial rate; (0, 1) when n is 0."""
    if n <= 0:
        return (0.0, 1.0)
    p = successes / n
    denom = 1 + z * z / n
    centre = (p + z * z / (2 * n)) / denom
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / denom
    # the interval always holds p itself (rounding leaves centre - half at ~1e-17 when p = 0)
    return (max(0.0, min(p, centre - half)), min(1.0, max(p, centre + half)))


def mean_interval(values, z: float = Z95) -> tuple[float, float, float]:
    """Mean and its normal-approximation 95 % interval."""
    v = np.asarray(values, dtype=float)
    if v.size == 0:
        return (float("nan"), float("nan"), float("nan"))
    m = float(v.mean())
    if v.size < 2:
        return (m, m, m)
    half = z * float(v.std(ddof=1)) / math.sqrt(v.size)
    return (m, m - half, m + half)


def t_interval(values) -> tuple[float, float, float]:
    """Mean over a few seeds and its Student-t 95 % interval."""
    from scipy import stats  # here: scipy.stats takes most of a second to import, and only `report` needs it

    v = np.asarray(values, dtype=float)
    m = float(v.mean())
    if v.size < 2:
        return (m, m, m)
    half = float(stats.t.ppf(0.975, v.size - 1)) * float(v.std(ddof=1)) / math.sqrt(v.size)
    return (m, m - half, m + half)


def paired_difference(base, other, resamples: int = 10_000, seed: int = 0) -> tuple[float, float, float]:
    """Mean of other - base over paired episodes (the same seeds on two tables) and its 95 % percentile
    bootstrap interval, resampling whole episode pairs: pairing removes the spread the starts themselves cause,
    which two independent Wilson intervals would count twice."""
    a = np.asarray(base, dtype=float)
    b = np.asarray(other, dtype=float)
    if a.shape != b.shape or a.size == 0:
        raise ValueError(f"paired outcomes need the same episodes on both tables, got {a.size} and {b.size}")
    difference = b - a
    rng = np.random.default_rng(seed)
    means = difference[rng.integers(0, difference.size, (resamples, difference.size))].mean(axis=1)
    low, high = np.percentile(means, [2.5, 97.5])
    return float(difference.mean()), float(low), float(high)


def episode_seeds(seed: int, episodes: int) -> list[int]:
    """The fixed seed set: the same episodes for every policy evaluated with the same --seed."""
    return [seed * 100_003 + i for i in range(episodes)]


def run_episodes(env, act: Callable[[np.ndarray], np.ndarray], seeds: list[int], progress: bool = False,
                 desc: str = "evaluate", new_episode: Optional[Callable[[], None]] = None) -> list[dict]:
    """One episode per seed, `act` choosing each control step's action; `new_episode` (a policy's reset) is called
    before each."""
    results = []
    for s in tqdm(seeds, desc=desc, unit="ep", disable=not progress):
        obs, _ = env.reset(seed=s)
        if new_episode is not None:
            new_episode()
        while True:
            obs, _, terminated, truncated, info = env.step(act(obs))
            if terminated or truncated:
                results.append(info["episode_stats"])
                break
    return results


def summarize(results: list[dict], extra: Optional[dict] = None) -> dict:
    """The JSON summary: rates with Wilson intervals, means with normal intervals, and the inflation
    (share of home goals scored with no home touch at all)."""
    n = len(results)
    if n == 0:
        raise ValueError("no episodes to summarize")

    def col(key):
        return np.array([r[key] for r in results], dtype=float)

    wins, losses = col("win").sum(), col("lose").sum()
    no_touch = col("goal_without_touch").sum()
    after_touch = col("goal_after_touch").sum()
    length = mean_interval(col("length"))
    touches = mean_interval(col("touches"))
    ret = mean_interval(col("return"))
    progress = mean_interval(col("progress_after_touch")[col("home_touched") > 0])
    summary = {
        "episodes": n,
        "win_rate": wins / n, "win_rate_ci95": wilson_interval(wins, n),
        "own_goal_rate": losses / n, "own_goal_rate_ci95": wilson_interval(losses, n),
        "goal_termination_rate": col("term_goal").mean(),
        "stagnant_rate": col("stagnant").mean(),
        "mean_length": length[0], "mean_length_ci95": length[1:],
        "mean_return": ret[0], "mean_return_ci95": ret[1:],
        "touches": touches[0], "touches_ci95": touches[1:],
        "touched_rate": col("home_touched").mean(),
        "goals_after_touch": after_touch / n, "goals_after_touch_ci95": wilson_interval(after_touch, n),
        "goals_without_touch": no_touch / n,
        "no_touch_goal_share": (no_touch / wins) if wins else None,
        "no_touch_goal_share_ci95": wilson_interval(no_touch, int(wins)) if wins else None,
        "progress_after_touch": progress[0], "progress_after_touch_ci95": progress[1:],
    }
    # Goals against by who touched the ball last (results written before 28 Nov lack the column)
    last = [r.get("own_goal_last_touch", "") for r in results if r.get("lose")]
    if all(last):
        summary["own_goals_by_last_touch"] = {who: sum(w == who for w in last) / n for who in ("home", "away", "both", "none")}
        rods = [r.get("own_goal_home_rod", "") for r in results if r.get("lose") and r.get("own_goal_last_touch") == "home"]
        summary["own_goals_by_home_rod"] = {rod: rods.count(rod) / n for rod in sorted(set(rods))}
    # Spins (foos_policy.spins; results written before 28 Nov lack the columns)
    if all("home_touches_spun" in r for r in results):
        touches_all = col("touches").sum()
        summary["spun_touch_share"] = col("home_touches_spun").sum() / touches_all if touches_all else None
        summary["own_goals_off_spins"] = col("own_goal_off_spin").mean()
        summary["goals_off_spins"] = col("goal_off_spin").mean()
        legal = wins - col("goal_off_spin").sum()
        summary["win_rate_without_spins"] = legal / n
        summary["win_rate_without_spins_ci95"] = wilson_interval(legal, n)
        summary["home_turns"] = col("home_turns").mean()
    if extra:
        summary.update(extra)
    return _plain(summary)


def _plain(value):
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_plain(v) for v in value]
    if isinstance(value, (np.floating, np.integer)):
        value = value.item()
    if isinstance(value, float) and not math.isfinite(value):
        return None
    return value
