"""The gain rule: an effect is named only if it lowers the held-out error of what it acts on.

Every effect the selection would name is judged on held-out predictions, each from a model fitted
without the data it predicts: its error without the effect and with it, on the starts (held-out
prediction starts) the effect acts on. The drop is the median error without it less the median with
it, and its 95 % interval comes from a block bootstrap that resamples whole held-out stretches (starts
in one stretch share the stretch's errors: resampling them one by one would narrow the interval). The
effect is kept only where that interval lies above zero, both alone (against the nominal model) and in
the final set (against the final set without it). The selections' own held-out evidence (squared-error
drops on folds) decides which effects to try; this rule decides which of them the report may name.
"""
from __future__ import annotations

import numpy as np

LEVEL = 0.95
N_BOOT = 1000
MIN_STARTS = 6  # held-out starts an effect must act on for its interval to mean anything


def drop_interval(without: np.ndarray, with_: np.ndarray, groups: np.ndarray, seed: int = 0, scale: float = 1.0,
                  weights: np.ndarray | None = None) -> dict:
    """The error without and with an effect, the drop, and its 95 % block-bootstrap interval.

    without, with_: (n,) per-start errors (NaN where unmeasured) on the same starts; groups: (n,) the
    held-out stretch of each start, resampled whole. `scale` converts the errors to the unit reported.
    The error is the median over starts; with `weights` (n,), the inputs are mean squared errors of
    pieces of that many samples, and the error is their RMS over all the samples (`statistic` says which)."""
    ok = np.isfinite(without) & np.isfinite(with_)
    without, with_, groups = without[ok], with_[ok], groups[ok]
    w = weights[ok] if weights is not None else None
    out = {"statistic": "median" if w is None else "rms", "starts": int(ok.sum()), "stretches": int(len(np.unique(groups)))}
    if out["starts"] < MIN_STARTS or out["stretches"] < 2:
        return {**out, "without": None, "with": None, "drop": None, "ci95_drop": None}

    def error(values, rows):
        if w is None:
            return np.median(values[rows]) * scale
        return np.sqrt(np.sum(w[rows] * values[rows]) / np.sum(w[rows])) * scale

    labels, index = np.unique(groups, return_inverse=True)
    members = [np.flatnonzero(index == g) for g in range(len(labels))]
    rng = np.random.default_rng(seed)
    boot = np.empty(N_BOOT)
    for b in range(N_BOOT):
        rows = np.concatenate([members[g] for g in rng.integers(0, len(members), size=len(members))])
        boot[b] = error(without, rows) - error(with_, rows)
    every = np.arange(len(without))
    tail = (1 - LEVEL) / 2 * 100
    return {**out, "without": _r(error(without, every)), "with": _r(error(with_, every)),
            "drop": _r(error(without, every) - error(with_, every)),
            "ci95_drop": [_r(np.percentile(boot, tail)), _r(np.percentile(boot, 100 - tail))]}


def excludes_zero(block: dict) -> bool:
    """Whether a drop's interval lies wholly above zero (a gain); no interval is no gain."""
    ci = block.get("ci95_drop")
    return ci is not None and ci[0] > 0


def _r(value: float) -> float:
    return round(float(value), 3)


def describe(gain: dict | None) -> str:
    """The gain in words for report.md: each interval's error without -> with the effect, and the drop's interval."""
    parts = []

    def walk(block, path):
        if not isinstance(block, dict):
            return
        if block.get("ci95_drop") is not None:
            lo, hi = block["ci95_drop"]
            parts.append(f"{' '.join(path) or 'error'} {block['without']} -> {block['with']} (drop {block['drop']}, "
                         f"95 % [{lo}, {hi}])")
        for key, value in block.items():
            walk(value, path + [key.replace('_', ' ')])

    walk(gain or {}, [])
    return "; ".join(parts) if parts else "no held-out gain measured"
