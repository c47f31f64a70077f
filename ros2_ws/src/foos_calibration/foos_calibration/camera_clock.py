"""camera_latency: the lag of the detection stamps behind the encoders' clock, from the ball's figure contacts.

A figure touches the ball where the ball is at the moment of the touch. Each kink of the ball's path
(figure_kinks: the moment and place two straight lines meet) is a touch when a figure, posed from the joint
states (figure_contacts.FigureModel, the model's own geometry), is in contact with the ball there; with
the right clock the gap between the ball and the nearest figure at the kink is zero. Posed at a stamp that
is `delay` late, a moving figure is where it was not yet, or no longer. So:

  gap_i(s) = distance from the ball at kink i to the figures posed at (t_i - s)

is computed for every kink on a grid of shifts s (SHIFTS, then a parabola through the least), and the delay
is the shift that minimises sum_i min(gap_i(s)^2, CAP^2) (a kink no shift brings to a figure, a wall's or a
push, costs the same at every shift). Kinks against figures at rest say nothing and cost nothing either way:
the kicks and the fast slides decide.

Named only on held-out evidence: the kinks alternate between two folds in time, each fold's delay is scored on
the other (the drop of its summed capped gap^2 from the zero shift, in detection-noise variances), and the
delay is named when both drops are positive, their sum is at least MIN_EVIDENCE, both folds' delays agree
(FOLD_AGREEMENT) and it is material (>= MIN_DELAY). The interval is a bootstrap over kinks.

Where a latency is named, the ball's detections are taken back by it (t - delay) before anything else uses
them: the figure contacts that cut the tracks, the bounces, the fits.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from . import effect_gain
from .figure_contacts import FigureModel, JointTrack
from .figure_kinks import Kink

SHIFTS = np.round(np.arange(-0.04, 0.1201, 0.001), 4)  # s: negative shifts too, so that "none" is inside the grid
CAP = 0.006  # m: a kink whose gap is larger at a shift costs this much there (robust to kinks that are no touch)
TOUCH = 0.004  # m: a kink counts as a figure touch when some shift brings a figure this close
MIN_KINKS = 20
MIN_EVIDENCE = 30.0  # noise variances of held-out drop
MIN_DELAY = 0.008  # s: a smaller latency is not named (about a frame at 120 fps is 8.3 ms)
FOLD_AGREEMENT = (0.006, 0.3)  # s, share: the folds' delays agree within max(6 ms, 30 %)
BOOTSTRAP = 200


@dataclass
class CameraClock:
    """What the latency search found: `delay` is None when the data does not support naming one."""

    delay: float | None
    fitted: float  # s, the best shift on all kinks (reported even when not named)
    evidence: dict
    block: dict  # report.json's `camera`
    effects: list[dict] = field(default_factory=list)  # [] or [camera_latency] in the contract's vocabulary


def gap_table(kinks: list[Kink], figures: FigureModel, joints: JointTrack, shifts: np.ndarray = SHIFTS) -> np.ndarray:
    """(kinks, shifts): the gap (m; < 0 overlapping) between the ball at each kink and the nearest figure posed
    at the kink's time minus each shift."""
    if not kinks:
        return np.zeros((0, len(shifts)))
    times = np.array([k.t for k in kinks])[:, None] - shifts[None, :]
    xy = np.repeat(np.array([k.xy for k in kinks]), len(shifts), axis=0)
    gaps = figures.distance(xy, joints.at(times.ravel()))
    return gaps.reshape(len(kinks), len(shifts))


def _cost(gaps: np.ndarray) -> np.ndarray:
    return np.minimum(gaps**2, CAP**2).sum(axis=0)


def _best(cost: np.ndarray, shifts: np.ndarray = SHIFTS) -> float:
    """The least of a cost over the shifts, refined by a parabola through it and its neighbours."""
    i = int(np.argmin(cost))
    if 0 < i < len(shifts) - 1:
        c0, c1, c2 = cost[i - 1], cost[i], cost[i + 1]
        curvature = c0 - 2 * c1 + c2
        if curvature > 0:
            return float(shifts[i] + 0.5 * (c0 - c2) / curvature * (shifts[1] - shifts[0]))
    return float(shifts[i])


def _cost_at(cost: np.ndarray, s: float, shifts: np.ndarray = SHIFTS) -> float:
    return float(np.interp(s, shifts, cost))


def find_camera_latency(kinks: list[Kink], figures: FigureModel, joints: JointTrack, noise: float,
                        seed: int = 0) -> CameraClock:
    """The camera's latency against the encoders (see the module's docstring)."""
    gaps = gap_table(kinks, figures, joints)
    touches = np.min(np.abs(gaps), axis=1) < TOUCH if len(gaps) else np.zeros(0, dtype=bool)
    gaps = gaps[touches]
    block = {"kinks": len(kinks), "figure_touches": int(len(gaps)), "method": (
        "shift of the detection stamps minimising the capped squared gap between the ball at its path's kinks and "
        "the figures posed from /joint_states at the shifted time; folds of alternating touches")}
    if len(gaps) < MIN_KINKS:
        reason = f"only {len(gaps)} figure touches located (need {MIN_KINKS})"
        return CameraClock(None, 0.0, {"reason": reason}, {**block, "named": False, "reason": reason})
    cost = _cost(gaps)
    fitted = _best(cost)
    sigma2 = max(noise, 1e-4) ** 2
    folds = np.arange(len(gaps)) % 2
    fold_delays, drops = [], []
    for k in (0, 1):
        s_k = _best(_cost(gaps[folds == k]))
        test = _cost(gaps[folds != k])
        fold_delays.append(s_k)
        drops.append((_cost_at(test, 0.0) - _cost_at(test, s_k)) / sigma2)
    rng = np.random.default_rng(seed)
    boot = [_best(_cost(gaps[rng.integers(0, len(gaps), len(gaps))])) for _ in range(BOOTSTRAP)]
    interval = [round(float(v), 4) for v in np.percentile(boot, [2.5, 97.5])]
    agree = abs(fold_delays[0] - fold_delays[1]) <= max(FOLD_AGREEMENT[0], FOLD_AGREEMENT[1] * abs(fitted))
    material = fitted >= MIN_DELAY
    # The gain rule (effect_gain): each touch's gap to the figures, held out (at the other fold's delay), without and
    # with the latency; each touch its own stretch.
    held = np.array([np.interp(fold_delays[1 - k], SHIFTS, np.abs(row)) for row, k in zip(gaps, folds)])
    gain = {"what": "median over figure touches of the ball's gap to the figures (mm), each touch at the other fold's delay",
            **effect_gain.drop_interval(np.abs(gaps[:, np.argmin(np.abs(SHIFTS))]), held, np.arange(len(gaps)), seed, 1000.0)}
    named = bool(sum(drops) >= MIN_EVIDENCE and min(drops) > 0 and agree and material and effect_gain.excludes_zero(gain))
    evidence = {
        "held_out_error_drop_noise_variances": round(float(sum(drops)), 1),
        "per_fold": [round(float(d), 1) for d in drops],
        "fold_delays_s": [round(float(d), 4) for d in fold_delays],
        "in_sample_error_drop_noise_variances": round(float((_cost_at(cost, 0.0) - _cost_at(cost, fitted)) / sigma2), 1),
        "figure_touches": int(len(gaps)),
        "ci95_s": interval,
        "material": bool(material),
        "folds_agree": bool(agree),
        "gain": gain,
    }
    if sum(drops) >= MIN_EVIDENCE and min(drops) > 0 and agree and material and not named:
        evidence["reason"] = "no held-out gain: the drop's 95 % interval does not lie above zero"
    block.update({"named": named, "fitted_delay_s": round(fitted, 4), "ci95_s": interval,
                  "fold_delays_s": evidence["fold_delays_s"], "held_out_drop_noise_variances": evidence["per_fold"],
                  "median_gap_mm_at_zero": round(float(np.median(np.abs(gaps[:, np.argmin(np.abs(SHIFTS))]))) * 1000, 2),
                  "median_gap_mm_at_fitted": round(float(np.median(np.abs(gaps[:, np.argmin(np.abs(SHIFTS - fitted))]))) * 1000, 2)})
    effects = [{"name": "camera_latency", "params": {"delay": round(fitted, 4)}, "evidence": evidence}] if named else []
    return CameraClock(round(fitted, 4) if named else None, fitted, evidence, block, effects)


def describe(effect: dict) -> str:
    """One plain sentence for report.md."""
    return (f"The camera's detections are stamped {effect['params']['delay'] * 1000:.1f} ms after the ball was where they say "
            "(against the rod encoders' clock); the ball's detections are taken back by it before the fit.")
