"""The gain: prediction error on held-out data, nominal against calibrated, on MuJoCo.

Starts are taken every START_SPACING along the rolling segments, each with at least HISTORY of
rolling data before it. The state at a start is estimated only from that history (each model's
own dynamics, least squares over the window), then MuJoCo rolls the ball forward and the error
against the detections is taken 0.25, 0.5 and 1 s ahead (through wall bounces; a horizon past the
end of the track is skipped). Calibrated predictions are cross-fitted: a start on a segment of one fold is
predicted by the model fitted on the other fold of segments, so no start's data was seen by its model.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from . import surrogate
from .fitting import DT, SegmentBatch, fit_states
from .mjsim import BallRollouts
from .tracks import Measured, Segment

HORIZONS = (0.25, 0.5, 1.0)
HISTORY = 0.3
START_SPACING = 0.4


@dataclass
class Start:
    track: int
    t0: float
    history: Segment
    fold: int = 0  # the fold of the segment it lies on


@dataclass
class Predictions:
    starts: list[Start]
    errors: dict[str, np.ndarray]  # model label -> (starts, horizons) error in m, NaN where unmeasured
    tracks: dict[str, tuple[np.ndarray, np.ndarray]]  # label -> (times, positions (starts, K, 2))
    states: dict[str, np.ndarray]


def choose_starts(measured: Measured, max_starts: int, seed: int = 0) -> list[Start]:
    starts = []
    for seg in measured.segments:
        t0 = max(seg.t[0], seg.rolls_from) + HISTORY  # a history of rolling only: a start's state is a rolling one
        while t0 <= seg.t[-1]:
            k = int(np.searchsorted(seg.t, t0, side="right"))
            m = (seg.t >= t0 - HISTORY) & (seg.t <= t0)
            if m.sum() >= 15:
                starts.append(Start(seg.track, float(seg.t[k - 1]), Segment(seg.track, seg.flight, seg.t[m], seg.xy[m]), seg.fold))
            t0 += START_SPACING
    if len(starts) > max_starts:
        rng = np.random.default_rng(seed)
        keep = np.sort(rng.choice(len(starts), size=max_starts, replace=False))
        starts = [starts[i] for i in keep]
    return starts


def estimate_states(starts: list[Start], thetas: list[np.ndarray]) -> np.ndarray:
    """(x, y, vx, vy) at each start from its history only, under the given model (one theta per start)."""
    batch = SegmentBatch([s.history for s in starts])
    out = np.zeros((len(starts), 4))
    for theta in {tuple(t) for t in thetas}:
        rows = [i for i, t in enumerate(thetas) if tuple(t) == theta]
        sub = SegmentBatch([starts[i].history for i in rows])
        f = fit_states(sub, np.array(theta))
        duration = np.array([starts[i].t0 - starts[i].history.t[0] for i in rows])
        p, v = surrogate.integrate_state(f.states[:, :2], f.states[:, 2:4], np.tile(np.array(theta), (len(rows), 1)), duration, DT)
        out[rows] = np.concatenate([p, v], axis=1)
    del batch
    return out


def measured_at(measured: Measured, track: int, times: np.ndarray) -> np.ndarray:
    """Detections of a track interpolated at times; NaN outside it or across a gap over 30 ms."""
    t, xy = measured.tracks[track]
    out = np.full((len(times), 2), np.nan)
    for i, ti in enumerate(times):
        k = int(np.searchsorted(t, ti))
        if 0 < k < len(t) and t[k] - t[k - 1] <= 0.03:
            w = (ti - t[k - 1]) / (t[k] - t[k - 1])
            out[i] = xy[k - 1] * (1 - w) + xy[k] * w
        elif k < len(t) and abs(t[k] - ti) < 1e-9:
            out[i] = xy[k]
    return out


def predict(measured: Measured, starts: list[Start], models: dict[str, tuple[list[dict], list[np.ndarray], list[int]]]) -> Predictions:
    """models: label -> (parameter trees, surrogate theta per start, tree index per start)."""
    errors, tracks, states = {}, {}, {}
    for label, (trees, thetas, index) in models.items():
        st = estimate_states(starts, thetas)
        sim = BallRollouts(trees)
        times, pos = sim.positions(index, st, max(HORIZONS), sample_dt=0.01)
        err = np.full((len(starts), len(HORIZONS)), np.nan)
        for i, s in enumerate(starts):
            truth = measured_at(measured, s.track, s.t0 + np.array(HORIZONS))
            for j, h in enumerate(HORIZONS):
                k = int(round(h / (times[1] - times[0])))
                err[i, j] = np.linalg.norm(pos[i, k] - truth[j])
        errors[label], tracks[label], states[label] = err, (times, pos), st
    return Predictions(starts, errors, tracks, states)


def summary(errors: np.ndarray, seed: int = 0, n_boot: int = 1000) -> dict:
    """Median error (mm) per horizon with a 95 % bootstrap interval over starts."""
    rng = np.random.default_rng(seed)
    out = {}
    for j, h in enumerate(HORIZONS):
        e = errors[:, j]
        e = e[np.isfinite(e)] * 1000
        key = f"{h:g}s".replace("0.", "0_") if h < 1 else "1s"
        if len(e) == 0:
            out[f"median_error_mm_{key}"] = None
            continue
        boot = np.median(rng.choice(e, size=(n_boot, len(e)), replace=True), axis=1)
        out[f"median_error_mm_{key}"] = round(float(np.median(e)), 2)
        out[f"ci95_mm_{key}"] = [round(float(np.percentile(boot, 2.5)), 2), round(float(np.percentile(boot, 97.5)), 2)]
        out[f"n_{key}"] = int(len(e))
    return out


def errors_of(measured: Measured, starts: list[Start], positions_at_horizons: np.ndarray) -> np.ndarray:
    """(starts, horizons) errors of predicted positions (starts, horizons, 2)."""
    err = np.full((len(starts), len(HORIZONS)), np.nan)
    for i, s in enumerate(starts):
        truth = measured_at(measured, s.track, s.t0 + np.array(HORIZONS))
        err[i] = np.linalg.norm(positions_at_horizons[i] - truth, axis=1)
    return err
