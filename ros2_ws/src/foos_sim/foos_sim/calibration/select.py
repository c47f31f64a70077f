"""Which effects the data supports: forward selection by held-out evidence.

Each round fits every remaining candidate added to the current set on all rolling segments and
takes the one that explains most. It is kept only if it also predicts data it was not fitted on:
the segments are split in two folds (alternating along the recording, so that a local effect such
as a dent is seen by both), the extended and the current model
are each fitted on one fold, and only their segments' initial states are re-fitted on the other.
The evidence is the drop of that held-out squared error, in units of the detection noise
variance, summed over both directions. A parameter that only soaks up noise does not predict the
other fold and earns no evidence.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from . import surrogate
from .fitting import Fit, SegmentBatch, dent_search, fit, fit_states, predicted_drops
from .tracks import Segment

ROLLING_CANDIDATES = ("table_tilt", "rolling_resistance", "viscous_damping", "air_drag", "surface_dent")
MIN_EVIDENCE = 30.0  # held-out squared-error drop, in noise variances, to name an effect
MIN_FOLD_SHARE = 0.05  # and neither fold may get worse by more than this share of the total (or 10)


def material(name: str, theta: np.ndarray, base: np.ndarray) -> bool:
    """Whether a fitted effect is big enough to matter (and beyond what the fit's own model gaps give).

    The floors sit below the smallest effects worth reporting (slope 0.002, rolling resistance off by
    half, 0.05 /s, 0.02 /m, a 1 mm dent) and above the biases measured on nominal data, e.g. a ball
    spinning about the vertical after a wall bounce rolls with up to 5 % less resistance in MuJoCo.
    """
    if name == "table_tilt":
        return float(np.hypot(theta[0] - base[0], theta[1] - base[1])) >= 0.001
    if name == "rolling_resistance":
        return abs(theta[2] - base[2]) >= 0.12 * base[2]
    if name == "viscous_damping":
        return abs(theta[3] - base[3]) >= 0.02
    if name == "air_drag":
        return abs(theta[4] - base[4]) >= 0.008
    if name == "surface_dent":
        if abs(theta[8]) >= 0.009 or theta[7] <= 0.031:  # at the fit's bounds: not a credible dent
            return False
        moved = np.hypot(theta[5] - base[5], theta[6] - base[6]) >= 0.03 if base[8] else True
        return abs(theta[8] - base[8]) >= 0.0005 or (moved and abs(theta[8]) >= 0.0005)
    return True


def free_indices(names) -> tuple[int, ...]:
    return tuple(sorted(i for name in names for i in surrogate.EFFECT_PARAMS[name]))


@dataclass
class Selection:
    effects: list[str]
    fit: Fit  # on all segments
    evidence: dict[str, dict]  # name -> numbers behind the decision
    fold_theta: list[np.ndarray]  # theta fitted on fold 0 and on fold 1 (for cross-fitted evaluation)
    rejected: dict[str, dict] = field(default_factory=dict)


class HeldOut:
    """Two folds of segments (alternating); caches each model's cross-fitted held-out error."""

    def __init__(self, segments: list[Segment]):
        self.folds = [[s for s in segments if s.fold == k] for k in (0, 1)]
        self.batches = [SegmentBatch(f) if f else None for f in self.folds]
        self.cache: dict[tuple, tuple[list[float], list[np.ndarray]]] = {}

    def usable(self) -> bool:
        return all(b is not None and b.n >= 2 for b in self.batches)

    def score(self, names: tuple[str, ...], theta_full: np.ndarray, current_thetas: list[np.ndarray] | None = None,
              new_dent: bool = False) -> tuple[list[float], list[np.ndarray]]:
        """Held-out RSS of fold 1 under fold 0's fit and of fold 0 under fold 1's, and those thetas.

        A new dent is searched for on the training fold alone: started from the all-data dent, a
        fold without data near it would keep it untouched and "predict" the other fold with it.
        """
        key = tuple(sorted(names))
        if key in self.cache:
            return self.cache[key]
        free = free_indices(names)
        thetas, rss = [], [0.0, 0.0]
        for k in (0, 1):
            train = self.batches[k]
            start = theta_full
            if new_dent and current_thetas is not None:
                start = current_thetas[k].copy()
                start[5:9] = dent_search(train, fit_states(train, current_thetas[k]))[0]
                for j in free:  # the other free parameters start where the all-data fit put them
                    if j < 5:
                        start[j] = theta_full[j]
            thetas.append(fit(train, free, start).theta if free else theta_full.copy())
        for k in (0, 1):
            test = self.batches[1 - k]
            rss[1 - k] = fit_states(test, thetas[k]).rss
        self.cache[key] = (rss, thetas)
        return rss, thetas


def select_effects(segments: list[Segment], noise: float, theta0: np.ndarray,
                   progress: Callable[[str], None] = lambda message: None) -> Selection:
    """Effects (changes to the base table theta0) the held-out evidence supports."""
    batch = SegmentBatch(segments)
    sigma2 = noise**2
    progress("fitting the nominal model's segment states")
    current = fit_states(batch, theta0)
    chosen: list[str] = []
    evidence: dict[str, dict] = {}
    rejected: dict[str, dict] = {}
    held = HeldOut(segments)
    if not held.usable():
        return Selection([], current, {}, [theta0, theta0], {"*": {"reason": "too few rolls for held-out folds"}})
    base_rss, base_thetas = held.score((), theta0)
    while True:
        remaining = [name for name in ROLLING_CANDIDATES if name not in chosen]
        if not remaining:
            break
        progress("ranking candidate effects")
        smooth = {name: surrogate.EFFECT_PARAMS[name] for name in remaining if name != "surface_dent"}
        drops = predicted_drops(batch, current, smooth) if smooth else {}
        dent_start = None
        if "surface_dent" in remaining:
            dent_start, drops["surface_dent"] = dent_search(batch, current)
        order = sorted(remaining, key=lambda k: -drops[k])
        accepted = False
        for name in order:
            if drops[name] / sigma2 < MIN_EVIDENCE:
                break
            progress(f"fitting {' + '.join(chosen + [name])}")
            start = current.theta.copy()
            if name == "surface_dent" and not theta0[8]:
                start[5:9] = dent_start
            if name in ("viscous_damping", "air_drag"):
                j = surrogate.EFFECT_PARAMS[name][0]
                start[j] = max(start[j], 1e-3)
            candidate = fit(batch, free_indices(chosen + [name]), start, current.states)
            progress(f"held-out check of {name}")
            rss, thetas = held.score(tuple(chosen + [name]), candidate.theta, base_thetas,
                                     new_dent=name == "surface_dent" and not theta0[8])
            # Evidence in units of what the extended model still leaves unexplained, when that is more than
            # the frame-to-frame noise: a camera's detections carry slowly varying errors (a ball partly
            # hidden under a rod is seen off centre for several frames) that second differences do not
            # see, and a local effect can soak up a few of them in one fold.
            dof = max(1, candidate.nres - 4 * batch.n - len(free_indices(chosen + [name])))
            scale2 = max(sigma2, candidate.rss / dof)
            fold_drops = [(b - r) / scale2 for b, r in zip(base_rss, rss)]
            info = {
                "held_out_error_drop_noise_variances": round(float(sum(fold_drops)), 1),
                "per_fold": [round(float(d), 1) for d in fold_drops],
                "in_sample_error_drop_noise_variances": round(float((current.rss - candidate.rss) / scale2), 1),
                "residual_scatter_over_noise": round(float(np.sqrt(scale2 / sigma2)), 2),
            }
            info["material"] = bool(material(name, candidate.theta, theta0))
            total = sum(fold_drops)
            if total >= MIN_EVIDENCE and min(fold_drops) >= -max(10.0, MIN_FOLD_SHARE * total) and info["material"]:
                chosen.append(name)
                evidence[name] = info
                current, base_rss, base_thetas = candidate, rss, thetas
                accepted = True
                break
            rejected[name] = info
        if not accepted:
            break
    return Selection(chosen, current, evidence, base_thetas, rejected)
