"""Wall restitution, fitted on MuJoCo rollouts through measured bounces.

A bounce window starts at the end of the rolling segment before a wall contact (state from the
rolling fit: the ball rolls there) and runs 0.25 s past the contact. MuJoCo replays every window for
each restitution on a grid (one batched rollout; one model per row), and each window's squared
error against the detections is kept per grid value. The restitution is the parabolic minimum of
the summed error; held-out evidence comes from the same table: fitted on every other bounce,
scored on the rest, and the other way round.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.interpolate import CubicSpline

from . import effect_gain, surrogate
from .fitting import DT, Fit
from .mjsim import BallRollouts, set_wall_restitution
from .tracks import Measured

GRID = np.round(np.arange(0.30, 0.981, 0.05), 3)
AFTER = 0.25  # s of data after the contact in a window
MIN_EVIDENCE = 30.0
MIN_CHANGE = 0.04  # restitution closer than this to the nominal one is not named


@dataclass
class BounceWindow:
    track: int
    wall: str
    t0: float
    state: np.ndarray  # x, y, vx, vy at t0 (rolling)
    t: np.ndarray  # detection times - t0
    xy: np.ndarray


@dataclass
class RestitutionResult:
    coefficient: float | None  # None: not supported by the data
    fitted: float
    evidence: dict
    windows: list[BounceWindow]
    rss: np.ndarray  # (windows, GRID)


def bounce_windows(measured: Measured, fit_: Fit) -> list[BounceWindow]:
    by_flight: dict[int, int] = {}
    for i, s in enumerate(measured.segments):
        by_flight[s.flight] = i  # the last segment of each flight
    windows = []
    for b in measured.bounces:
        i = by_flight.get(b.before)
        if i is None:
            continue
        seg = measured.segments[i]
        before, after = measured.flights[b.before], measured.flights[b.after]
        if before.t[-1] - seg.t[-1] > 0.05 or len(after.t) < 8:
            continue
        duration = np.array([seg.t[-1] - seg.t[0]])
        slip = fit_.states[i:i + 1, 4:6]
        if surrogate.slide_duration(slip)[0] >= duration[0]:
            continue  # still sliding when it reached the wall: MuJoCo is started from a rolling ball
        p, v = surrogate.integrate_state(fit_.states[i:i + 1, :2], fit_.states[i:i + 1, 2:4], fit_.theta[None], duration, DT,
                                         slip=slip)
        t0 = seg.t[-1]
        end = min(b.t_contact + AFTER, after.t[-1])
        t_all = np.concatenate([before.t[before.t > t0], after.t[after.t <= end]])
        xy_all = np.concatenate([before.xy[before.t > t0], after.xy[after.t <= end]])
        if end - b.t_contact < 0.1 or len(t_all) < 8:
            continue
        windows.append(BounceWindow(b.track, b.wall, t0, np.concatenate([p[0], v[0]]), t_all - t0, xy_all))
    return windows


def window_errors(windows: list[BounceWindow], params: dict, grid=GRID) -> np.ndarray:
    """Squared error (windows, grid) of MuJoCo replays through each bounce for each restitution."""
    trees = [params for _ in grid]
    sim = BallRollouts(trees)
    for model, e in zip(sim.models, grid):
        set_wall_restitution(model, params, float(e))
    n, k = len(windows), len(grid)
    index = [j for _ in range(n) for j in range(k)]
    states = np.repeat(np.array([w.state for w in windows]), k, axis=0)
    duration = max(w.t[-1] for w in windows) + 0.01
    times, pos = sim.positions(index, states, duration, sample_dt=0.0025)
    rss = np.zeros((n, k))
    for i, w in enumerate(windows):
        for j in range(k):
            row = pos[i * k + j]
            px = np.interp(w.t, times, row[:, 0])
            py = np.interp(w.t, times, row[:, 1])
            rss[i, j] = np.sum((px - w.xy[:, 0]) ** 2 + (py - w.xy[:, 1]) ** 2)
    return rss


def spline_minimum(total: np.ndarray, grid=GRID, points: int = 681) -> float:
    """The restitution where a cubic spline through the errors on `grid` is least, read on `points` between its ends
    (681 on the walls' grid: about 0.001 apart)."""
    fine = np.linspace(grid[0], grid[-1], points)
    return float(fine[np.argmin(CubicSpline(grid, total)(fine))])


def spline_at(total: np.ndarray, e: float, grid=GRID) -> float:
    """The error at restitution e, by the same spline."""
    return float(CubicSpline(grid, total)(e))


def fit_restitution(measured: Measured, fit_: Fit, params: dict, nominal: float, noise: float) -> RestitutionResult:
    windows = bounce_windows(measured, fit_)
    if len(windows) < 4:
        return RestitutionResult(None, nominal, {"reason": f"only {len(windows)} usable bounces"}, windows, np.zeros((0, len(GRID))))
    rss = window_errors(windows, params)
    total = rss.sum(axis=0)
    fitted = spline_minimum(total)
    folds = np.arange(len(windows)) % 2
    sigma2 = noise**2
    drops = []
    for k in (0, 1):
        train, test = rss[folds == k].sum(axis=0), rss[folds != k].sum(axis=0)
        if not np.any(folds == k) or not np.any(folds != k):
            drops.append(0.0)
            continue
        e_k = spline_minimum(train)
        drops.append((spline_at(test, nominal) - spline_at(test, e_k)) / sigma2)
    evidence = {
        "held_out_error_drop_noise_variances": round(float(sum(drops)), 1),
        "per_fold": [round(float(d), 1) for d in drops],
        "in_sample_error_drop_noise_variances": round(float((spline_at(total, nominal) - spline_at(total, fitted)) / sigma2), 1),
        "bounces": len(windows),
        "material": bool(abs(fitted - nominal) >= MIN_CHANGE),
        "gain": _gain(windows, rss, folds, nominal),
    }
    named = (sum(drops) >= MIN_EVIDENCE and min(drops) > 0 and evidence["material"]
             and effect_gain.excludes_zero(evidence["gain"]))
    return RestitutionResult(fitted if named else None, fitted, evidence, windows, rss)


def held_out_replay_gain(windows: list[BounceWindow], rss: np.ndarray, folds: np.ndarray, baseline: float,
                         seed: int = 0) -> tuple[list[float], dict]:
    """The restitution fitted on each fold's bounces, and the gain rule's block (effect_gain) over the windows: each
    window's replay RMS error (mm) at `baseline` against that at the other fold's coefficient; each bounce its own
    stretch. Shared by the table's restitution and each stretch of wall (wall_segments)."""
    fold_e = [spline_minimum(rss[folds == k].sum(axis=0)) if np.any(folds == k) else baseline for k in (0, 1)]
    points = np.array([2 * max(len(w.t), 1) for w in windows])
    without = np.array([np.sqrt(max(spline_at(row, baseline), 0.0) / n) for row, n in zip(rss, points)])
    with_ = np.array([np.sqrt(max(spline_at(row, fold_e[1 - k]), 0.0) / n) for row, k, n in zip(rss, folds, points)])
    return fold_e, effect_gain.drop_interval(without, with_, np.arange(len(windows)), seed=seed, scale=1000.0)


def _gain(windows: list[BounceWindow], rss: np.ndarray, folds: np.ndarray, nominal: float) -> dict:
    """The table's restitution under the gain rule, held out (at the coefficient fitted on the other fold's bounces)."""
    _, gain = held_out_replay_gain(windows, rss, folds, nominal)
    return {"what": "median over wall bounces of the replay's RMS ball error (mm), each at the other fold's coefficient",
            **gain}


def fold_restitution(result: RestitutionResult, fold: int, nominal: float) -> float:
    """Restitution fitted on one fold's bounces (nominal when none or not named)."""
    if result.coefficient is None:
        return nominal
    folds = np.arange(len(result.windows)) % 2
    if not np.any(folds == fold):
        return result.coefficient
    return spline_minimum(result.rss[folds == fold].sum(axis=0))
