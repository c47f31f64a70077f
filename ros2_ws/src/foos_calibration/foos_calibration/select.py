"""Which effects the data supports: forward selection by held-out evidence, then a revision.

Each round fits every remaining candidate added to the current set on all rolling segments and
takes the one that explains most. It is kept only if it also predicts data it was not fitted on:
the segments are split in two folds (alternating along the recording), the extended and the
current model are each fitted on one fold, and only their segments' initial states are re-fitted
on the other. The evidence is the drop of that held-out squared error, in units of the detection
noise variance, summed over both directions. A parameter that only soaks up noise does not predict
the other fold and earns no evidence. A dent is local: only the few rolls that cross it carry
evidence, so it is judged on those, each predicted by a dent found without it (or, where too few
cross it for that, on alternate frames of them at twice the bar). Finally each named
effect must still earn its evidence given the others, and a named speed law is swapped for another
when that predicts the held-out folds better (greedy order confuses them).
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Callable

import numpy as np

from foos_core.table_geometry import TableGeometry

from . import surrogate
from .fitting import (
    DENT_REACH,
    MAX_DENT_DEPTH,
    Fit,
    SegmentBatch,
    dent_search,
    fit,
    fit_states,
    linearised_rss,
    predicted_drops,
)
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


SCATTER_WINDOW = 0.25  # s: pieces of a segment over which a quadratic in t follows any rolling ball's path


def measurement_scatter(segments: list[Segment]) -> float:
    """The detections' own scatter (m, per axis) about a smooth path, whatever the physics: the variance unit.

    Each segment is cut into pieces of SCATTER_WINDOW and a quadratic in t is fitted to each. Over a
    quarter second a rolling ball's path is a quadratic to well under the noise, whatever tilts, dents or
    losses act on it, so what is left is the camera's: the white noise the second differences measure and
    the errors that last several frames (a ball half under a rod seen off centre), which they do not.
    Evidence is counted in this unit. It used to be the candidate model's own residual scatter, which
    includes every misfit of that model: with a tilt and a dent hidden together, the tilt alone left 7.9x
    the noise and its evidence shrank 60-fold, exactly when the model was most wrong.
    """
    rss, dof = 0.0, 0
    for segment in segments:
        edges = np.arange(segment.t[0], segment.t[-1] + SCATTER_WINDOW, SCATTER_WINDOW)
        piece = np.searchsorted(edges, segment.t, side="right") - 1
        for k in np.unique(piece):
            m = piece == k
            if m.sum() < 8:
                continue
            tau = segment.t[m] - segment.t[m].mean()
            design = np.stack([np.ones_like(tau), tau, tau**2], axis=1)
            _, residual, *_ = np.linalg.lstsq(design, segment.xy[m], rcond=None)
            if residual.size:
                rss += float(residual.sum())
                dof += 2 * (int(m.sum()) - 3)
    return float(np.sqrt(rss / dof)) if dof else 0.0


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
    """Two folds of segments (alternating) of a table; caches each model's cross-fitted held-out error."""

    def __init__(self, segments: list[Segment], geometry: TableGeometry):
        self.geometry = geometry
        self.folds = [[s for s in segments if s.fold == k] for k in (0, 1)]
        self.rows = [np.array([i for i, s in enumerate(segments) if s.fold == k], dtype=int) for k in (0, 1)]
        self.batches = [SegmentBatch(f) if f else None for f in self.folds]
        self.cache: dict[tuple, tuple[list[float], list[np.ndarray]]] = {}

    def usable(self) -> bool:
        return all(b is not None and b.n >= 2 for b in self.batches)

    def score(self, names: tuple[str, ...], full: Fit) -> tuple[list[float], list[np.ndarray]]:
        """Held-out RSS of fold 1 under fold 0's fit and of fold 0 under fold 1's, and those thetas.

        Each fold's fit, and each held-out refit of a fold's segment states, starts from the all-data
        fit `full` of the same effects (its parameters, and its states of those segments). Started from
        each segment's quadratic guess instead, the state fits of a long game stop at their evaluation
        limit short of the minimum (a 238 fps game: 82 segments, 480 unknowns, half the held-out
        scoring's time), and the held-out error then carries how far each fit got, not only the model.
        A dent is not refitted per fold (a fold may have no roll over it, and then its dent is
        anything): it is judged by `dent_held_out_drops`, and once named it is carried along, as
        fitted on all data, while the other effects are judged.
        """
        key = tuple(sorted(names))
        if key in self.cache:
            return self.cache[key]
        # A named dent is held where all the data put it: half the rolls may have none over it to refit it.
        free = free_indices([name for name in names if name != "surface_dent"])
        states = [full.states[rows] for rows in self.rows]
        thetas, rss = [], [0.0, 0.0]
        for k in (0, 1):
            thetas.append(fit(self.batches[k], free, full.theta, states[k], geometry=self.geometry).theta
                          if free else full.theta.copy())
        for k in (0, 1):
            rss[1 - k] = fit_states(self.batches[1 - k], thetas[k], states[1 - k]).rss
        self.cache[key] = (rss, thetas)
        return rss, thetas


LOO_MIN_GAIN = 10.0  # noise variances the other rolls' dent must explain of their own data to be tested
FRAME_SPLIT_EVIDENCE = 60.0  # noise variances a dent judged on alternate frames must earn: twice the usual bar


def _crossing_rows(segments: list[Segment], dent: np.ndarray) -> np.ndarray:
    """The indices of the segments that pass within a search reach of the dent (x, y, radius, ...)."""
    centre, radius = dent[5:7], dent[7]
    return np.array([i for i, s in enumerate(segments)
                     if np.min(np.hypot(s.xy[:, 0] - centre[0], s.xy[:, 1] - centre[1])) < radius + DENT_REACH], dtype=int)


def _crossing(segments: list[Segment], dent: np.ndarray) -> list[Segment]:
    """The segments that pass within a search reach of the dent."""
    return [segments[i] for i in _crossing_rows(segments, dent)]


def dent_held_out_drops(segments: list[Segment], without: np.ndarray, with_dent: np.ndarray, scale2: float,
                        states_without: np.ndarray | None = None, states_with: np.ndarray | None = None) -> list[float]:
    """Held-out evidence for a new dent, judged only on the rolls that cross it (leave one roll out).

    Only the few rolls that pass over a dent carry any evidence of it, and two folds of all rolls
    split those few by chance: a fold left with none can only guess. So each crossing roll in turn
    is predicted by a dent found without it: a matched-filter search near the all-data dent on the
    other crossing rolls. A roll the others cannot vouch for earns nothing. Returns each crossing
    roll's drop in squared error, in units of scale2.

    states_without and states_with, where given, are the all-data fits' states of `segments` (one row each) under
    `without` and `with_dent`: each state fit starts from its segments' rows, as HeldOut.score's do (from each
    segment's quadratic guess, the fits of the other rolls, n - 1 of n each time, stop at their evaluation limit)."""
    rows = _crossing_rows(segments, with_dent)
    crossing = [segments[i] for i in rows]

    def start(states: np.ndarray | None, picks: list[int]) -> np.ndarray | None:
        return None if states is None else states[picks]

    drops = []
    for i, roll in enumerate(crossing):
        others = crossing[:i] + crossing[i + 1:]
        other_rows = [int(r) for r in np.delete(rows, i)]
        if not others:
            drops.append(0.0)
            continue
        batch = SegmentBatch(others)
        dent, gain = dent_search(batch, fit_states(batch, without, start(states_without, other_rows)), around=with_dent[5:8])
        # Only a dent the other rolls clearly show (not one at the depth limit, which is what
        # rolls with nothing to say about it give) is put to the test; a roll with none to test earns nothing.
        if gain / scale2 < LOO_MIN_GAIN or abs(dent[3]) >= MAX_DENT_DEPTH:
            drops.append(0.0)
            continue
        theta = without.copy()
        theta[5:9] = dent
        alone = SegmentBatch([roll])
        without_rss = fit_states(alone, without, start(states_without, [rows[i]])).rss
        drops.append((without_rss - fit_states(alone, theta, start(states_with, [rows[i]])).rss) / scale2)
    return drops


def dent_frame_split_drops(segments: list[Segment], without: np.ndarray, with_dent: np.ndarray, scale2: float,
                           geometry: TableGeometry | None = None) -> list[float]:
    """Held-out evidence for a dent from alternate frames of the rolls that cross it.

    For a dent that too few rolls crossed for `dent_held_out_drops` to check (often one slow roll
    carries hundreds of noise variances of it). The dent is searched near the all-data dent and
    fitted on the even frames, and judged on the odd ones (their states refitted with and without
    it), then the other way round. Noise does not repeat from one frame to the next, so a dent that only soaks it
    up earns nothing; an error that does repeat (a misfit of the model along one roll) could, which
    is why this route needs FRAME_SPLIT_EVIDENCE rather than MIN_EVIDENCE. Returns the two drops. The
    dent's centre stays on the field of `geometry` (the regulation table's by default).
    """
    crossing = _crossing(segments, with_dent)
    halves = [[replace(s, t=s.t[k::2], xy=s.xy[k::2]) for s in crossing] for k in (0, 1)]
    drops = []
    for k in (0, 1):
        train, test = SegmentBatch(halves[k]), SegmentBatch(halves[1 - k])
        train_fit = fit_states(train, without)
        dent, _ = dent_search(train, train_fit, around=with_dent[5:8])
        # The search's grid (1 cm, 1.5 cm of radius) and its linearisation leave about half of a
        # dent's held-out evidence unclaimed; the nonlinear fit of the dent alone on the training
        # half claims it, and on recordings without a dent it earns no more than the grid did. One
        # roll often cannot tell a narrow deep bowl from a wide shallow one, so the half's dent may
        # sit at the depth limit: the other half's frames still judge how well it predicts them.
        theta = without.copy()
        theta[5:9] = dent
        theta = fit(train, surrogate.EFFECT_PARAMS["surface_dent"], theta, train_fit.states, geometry=geometry).theta
        drops.append((fit_states(test, without).rss - fit_states(test, theta).rss) / scale2)
    return drops


def select_effects(segments: list[Segment], noise: float, theta0: np.ndarray, geometry: TableGeometry,
                   progress: Callable[[str], None] = lambda message: None) -> Selection:
    """Effects (changes to the base table theta0, whose field `geometry` is) the held-out evidence supports."""
    batch = SegmentBatch(segments)
    sigma2 = noise**2
    # The variance unit: the noise, or the camera's scatter about a smooth path where that is larger.
    unit2 = max(sigma2, measurement_scatter(segments) ** 2)
    progress("fitting the nominal model's segment states")
    current = fit_states(batch, theta0)
    chosen: list[str] = []
    evidence: dict[str, dict] = {}
    rejected: dict[str, dict] = {}
    held = HeldOut(segments, geometry)
    if not held.usable():
        return Selection([], current, {}, [theta0, theta0], {"*": {"reason": "too few rolls for held-out folds"}})
    base_rss, base_thetas = held.score((), current)
    while True:
        remaining = [name for name in ROLLING_CANDIDATES if name not in chosen]
        if not remaining:
            break
        progress("ranking candidate effects")
        smooth = {name: surrogate.EFFECT_PARAMS[name] for name in remaining if name != "surface_dent"}
        drops = predicted_drops(batch, current, smooth) if smooth else {}
        dent_start = None
        if "surface_dent" in remaining:
            dent_start, drops["surface_dent"] = dent_search(batch, current, geometry)
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
            candidate = fit(batch, free_indices(chosen + [name]), start, current.states, geometry=geometry)
            progress(f"held-out check of {name}")
            new_dent = name == "surface_dent" and not theta0[8]
            rss, thetas = held.score(tuple(chosen + [name]), candidate)
            # Evidence in units of what the extended model still leaves unexplained, when that is more than
            # the frame-to-frame noise: a camera's detections carry slowly varying errors (a ball partly
            # hidden under a rod is seen off centre for several frames) that second differences do not
            # see, and a local effect can soak up a few of them in one fold.
            dof = max(1, candidate.nres - batch.nstate - len(free_indices(chosen + [name])))
            scale2 = unit2
            info = {"in_sample_error_drop_noise_variances": round(float((current.rss - candidate.rss) / scale2), 1),
                    "residual_scatter_over_noise": round(float(np.sqrt(candidate.rss / dof / sigma2)), 2),
                    "variance_unit_over_noise": round(float(np.sqrt(scale2 / sigma2)), 2)}
            if new_dent:
                fold_drops = dent_held_out_drops(segments, current.theta, candidate.theta, scale2, current.states,
                                                 candidate.states)
                info["per_roll_over_the_dent"] = [round(float(d), 1) for d in fold_drops]
                consistent = _consistent(fold_drops)
                supported = sum(d > 0 for d in fold_drops) >= 2 and consistent and sum(fold_drops) >= MIN_EVIDENCE
                # A roll that the other rolls' dent predicts worse is held-out evidence against the dent: alternate
                # frames, the route for dents too few rolls cross to check one against the others, cannot overrule it
                # (a nominal 204 fps game: one roll at -82.7 noise variances, and 218 on alternate frames of the rolls).
                info["contradicted_by_a_roll"] = not consistent
                if not supported and consistent:
                    # Too few rolls to check one against the others: alternate frames, at a higher bar.
                    frame_drops = dent_frame_split_drops(segments, current.theta, candidate.theta, scale2, geometry)
                    info["per_frame_half"] = [round(float(d), 1) for d in frame_drops]
                    supported = sum(frame_drops) >= FRAME_SPLIT_EVIDENCE and min(frame_drops) > 0
                    if supported:
                        fold_drops = frame_drops
            else:
                fold_drops = [(b - r) / scale2 for b, r in zip(base_rss, rss)]
                info["per_fold"] = [round(float(d), 1) for d in fold_drops]
                supported = _consistent(fold_drops)
            info["held_out_error_drop_noise_variances"] = round(float(sum(fold_drops)), 1)
            info["material"] = bool(material(name, candidate.theta, theta0))
            if name == "surface_dent" and abs(candidate.theta[8]) > 0.99 * MAX_DENT_DEPTH:
                # Pressed against the depth limit: a narrow deep bowl trading against a wide shallow one,
                # or a misfit, not a dent this data locates.
                info["at_depth_limit"] = True
                supported = False
            if sum(fold_drops) >= MIN_EVIDENCE and supported and info["material"]:
                chosen.append(name)
                evidence[name] = info
                current, base_rss, base_thetas = candidate, rss, thetas
                accepted = True
                break
            rejected[name] = info
        if not accepted:
            break
    if len(chosen) >= 1:
        chosen, current, base_rss, base_thetas = _revise(batch, held, chosen, current, base_rss, base_thetas, theta0,
                                                          unit2, evidence, rejected, progress)
    return Selection(chosen, current, evidence, base_thetas, rejected)


def _consistent(drops: list[float]) -> bool:
    """No part of the held-out data gets worse by more than MIN_FOLD_SHARE of the total (or 10)."""
    return min(drops) >= -max(10.0, MIN_FOLD_SHARE * sum(drops))


SMOOTH = ("table_tilt", "rolling_resistance", "viscous_damping", "air_drag")
MIN_SWAP_GAIN = 5.0  # held-out noise variances a swapped set must gain, so that ties do not flip
# A set whose all-data fit would, by one Gauss-Newton step, leave this many noise variances more than the
# current set is not fitted and judged on held-out data: held out, it could not come within MIN_EVIDENCE or
# MIN_SWAP_GAIN of the current set (the folds add a few noise variances per parameter, not hundreds). Each
# full check costs a fit on all data and two on the folds, most of a calibration's time.
REVISION_SCREEN = 10 * MIN_EVIDENCE


def _revise(batch, held, chosen, current, base_rss, base_thetas, theta0, unit2, evidence, rejected, progress):
    """Forward selection's first choices, reconsidered once the others are in.

    Greedy order can name the wrong law: a constant plus a linear loss looks, before either is in,
    most like a quadratic one, and once the quadratic is in, neither of the true two adds enough on
    its own. So each named effect is dropped if the others now explain what it did (its held-out
    evidence, given the rest, falls under the threshold), and each named smooth effect is swapped
    for an unnamed one when the swapped set predicts the held-out folds better.
    """
    def refit(names):
        start = theta0.copy()
        for name in names:
            for j in surrogate.EFFECT_PARAMS[name]:
                start[j] = current.theta[j] if name in chosen else start[j]
            if name in ("viscous_damping", "air_drag") and name not in chosen:
                j = surrogate.EFFECT_PARAMS[name][0]
                start[j] = max(start[j], 1e-3)
        full = fit(batch, free_indices(names), start, current.states, geometry=held.geometry)
        rss, thetas = held.score(tuple(names), full)
        return full, rss, thetas

    def worse_than_current(sets, scale2) -> dict[tuple, float]:
        """Noise variances each set of names, refitted, would leave over the current set (one linearised step)."""
        if not sets:
            return {}
        rss = linearised_rss(batch, current, theta0, [free_indices(names) for names in sets])
        return {tuple(names): (r - current.rss) / scale2 for names, r in zip(sets, rss)}

    for _ in range(4):  # each pass either changes the set or ends
        changed = False
        scale2 = unit2  # the camera's scatter, never the misfit (measurement_scatter)
        named = [c for c in chosen if c in SMOOTH]  # a dent was judged on the rolls over it
        rests = {name: [c for c in chosen if c != name] for name in named}
        swaps = {(name, other): [other if c == name else c for c in chosen]
                 for name in named for other in SMOOTH if other not in chosen}
        worse = worse_than_current(list(rests.values()) + list(swaps.values()), scale2)
        for name in named:
            rest = rests[name]
            progress(f"checking {name} given {' + '.join(rest) or 'nothing else'}")
            if worse[tuple(rest)] > REVISION_SCREEN:
                evidence.setdefault(name, {})["in_sample_error_drop_given_the_others_linearised"] = round(float(worse[tuple(rest)]), 1)
                continue
            if rest:
                full, rss, thetas = refit(rest)
            else:
                full = fit_states(batch, theta0)
                rss, thetas = held.score((), full)
            worth = (sum(rss) - sum(base_rss)) / scale2
            evidence.setdefault(name, {})["held_out_error_drop_given_the_others"] = round(float(worth), 1)
            if worth < MIN_EVIDENCE:
                rejected[name] = {**evidence.pop(name), "reason": "the other named effects explain it"}
                chosen, current, base_rss, base_thetas = rest, full, rss, thetas
                changed = True
                break
        if changed:
            continue
        for name in named:
            for other in [c for c in SMOOTH if c not in chosen]:
                names = swaps[(name, other)]
                if worse[tuple(names)] > REVISION_SCREEN:
                    continue
                progress(f"trying {other} in place of {name}")
                full, rss, thetas = refit(names)
                gain = (sum(base_rss) - sum(rss)) / scale2
                if gain >= MIN_SWAP_GAIN and material(other, full.theta, theta0):
                    info = {"held_out_error_drop_noise_variances": evidence.get(name, {}).get(
                        "held_out_error_drop_noise_variances"), "swapped_in_for": name,
                        "held_out_gain_over_it_noise_variances": round(float(gain), 1), "material": True}
                    rejected[name] = {**evidence.pop(name, {}), "reason": f"{other} predicts the held-out folds better"}
                    evidence[other] = info
                    chosen, current, base_rss, base_thetas = names, full, rss, thetas
                    changed = True
                    break
            if changed:
                break
        if not changed:
            break
    return chosen, current, base_rss, base_thetas
