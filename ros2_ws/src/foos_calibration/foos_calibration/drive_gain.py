"""The gain rule for drive effects: a drive effect is named only if it lowers the held-out joint error of the
drives it acts on, alone and in the final set (the set without it -> the set). Alone is the effect added to what its
drives are given by the effects that have passed this check before it, in the order latency, speed limit,
acceleration limit (nominal -> nominal + it where none has): a rate limit behind a speed clip cannot gain on nominal
drives that run past the true speed, and only effects that gained on their own make up what it is judged against.

The error is the joint position error GAIN_HORIZON ahead from the identification's held-out starts (every
0.2 s; each start predicted with the limits fitted on the other fold of 4 s stretches: rods.prediction_errors),
each start's mean over the drives the effect acts on, per axis (slides in mm, rotations in degrees). Every
axis the effect acts on must gain: the 95 % interval of the drop in median error, stretches resampled whole
(effect_gain.drop_interval), lies above zero. An axis with fewer than effect_gain.MIN_STARTS starts off the
travel stops (the goalie's short slide is at a stop most of a game) is reported without an interval and
not judged; at least one axis must be. A speed or acceleration limit's slide and rotation parts act on different
drives: where one part gains and the other does not, only the part without a gain is refused.
"""
from __future__ import annotations

import json
import warnings
from typing import Callable

import numpy as np

from foos_core.names import AXES, JOINT_NAMES
from foos_sim.drive_limits import DriveLimits, drive_limits_from_effects

from . import effect_gain

GAIN_HORIZON = 0.25  # s: the horizon the gain rule judges (one of rods.HORIZONS)
HORIZON_INDEX = 1  # its place in rods.HORIZONS (0.1, 0.25)
PARTS = ("alone", "in_final_set")
WHAT = "median over held-out starts of the joint position error of the drives it acts on"
# fold effect sets ([fold 0's effects, fold 1's]) -> ((starts, horizons, 16) held-out errors, each start's stretch)
ErrorsOf = Callable[[list[list[dict]]], tuple[np.ndarray, np.ndarray]]


def _key(effect: dict) -> tuple:
    p = effect["params"]
    return (effect["name"], p.get("team"), p.get("rod"), p.get("axis"))


def _limits(effects: list[dict]) -> DriveLimits:
    limits = drive_limits_from_effects(effects)
    n = len(JOINT_NAMES)
    return limits if limits is not None else DriveLimits(np.zeros(n), np.full(n, np.inf), np.full(n, np.inf))


def acts_on(with_effect: list[dict], without: list[dict]) -> np.ndarray:
    """(16,) the drives whose limits differ between two effect sets."""
    a, b = _limits(with_effect), _limits(without)
    return (a.delay != b.delay) | (a.speed != b.speed) | (a.acceleration != b.acceleration)


def axis_gains(without: np.ndarray, with_: np.ndarray, drives: np.ndarray, stretch: np.ndarray, seed: int) -> dict:
    """Per axis the effect acts on: the error without and with it, the drop and its interval."""
    slide = np.array([n.endswith("_slide") for n in JOINT_NAMES])
    out = {}
    for axis, mask, scale, unit in (("slide", slide, 1000.0, "mm"), ("rotate", ~slide, 180.0 / np.pi, "deg")):
        cols = drives & mask
        if not cols.any():
            continue
        with warnings.catch_warnings():  # a start whose drives were all at a stop is NaN, and left out
            warnings.simplefilter("ignore", RuntimeWarning)
            pair = [np.nanmean(errors[:, HORIZON_INDEX][:, cols], axis=1) for errors in (without, with_)]
        out[f"{axis}_{unit}"] = effect_gain.drop_interval(pair[0], pair[1], stretch, seed, scale)
    return out


ORDER = ("rod_latency", "rod_speed_limit", "rod_acceleration_limit")  # the order drive effects are judged alone in


def _in_order(effects: list[dict]) -> list[dict]:
    """Latency, then speed limits, then acceleration limits (each behind the one before it on the way from command to
    motion); of one kind, the one with more held-out evidence first."""
    return sorted(effects, key=lambda e: (ORDER.index(e["name"]),
                                          -e.get("evidence", {}).get("held_out_error_drop_noise_variances", 0.0)))


def _memoised(errors_of: ErrorsOf) -> ErrorsOf:
    """errors_of, computed once per distinct pair of fold sets (a set is judged again after each refusal)."""
    cache: dict[str, tuple[np.ndarray, np.ndarray]] = {}

    def errors(fold_sets: list[list[dict]]) -> tuple[np.ndarray, np.ndarray]:
        key = json.dumps([sorted((e["name"], sorted(e["params"].items())) for e in fold) for fold in fold_sets], default=str)
        if key not in cache:
            cache[key] = errors_of(fold_sets)
        return cache[key]
    return errors


def _judged(blocks: dict) -> list[dict]:
    return [block for block in blocks.values() if block["ci95_drop"] is not None]


def _earned(blocks: dict) -> bool:
    """Every judged axis gains, and at least one is judged (one without enough starts off its stops is not)."""
    judged = _judged(blocks)
    return bool(judged) and all(effect_gain.excludes_zero(block) for block in judged)


def _judge_alone(errors: ErrorsOf, kept: list[dict], folds: list[list[dict]], nominal_errors, stretch, seed: int) -> list:
    """Each effect, in _in_order, against nominal plus the effects on the same drives that have already passed this check
    (evidence.gain.alone; .alone_with names those effects); then each that failed, again beside what has passed since
    (until nothing changes). Returns the effects that fail it.

    The second round: a latency is judged first, against nominal drives; where a speed limit is hidden too, those
    drives run far past it (to 314 rad/s on the jerk-limited drives, 27 rad/s hidden) and a dead time hardly moves that
    error, so a 52 ms latency was refused alone while the speed limit passed (robot-bench-5, trial 12). Judged beside
    the speed limit, it gains. What it is judged beside still passed without it, so nothing passes on its own support."""
    passed: dict[tuple, set[str] | None] = {}  # key -> the axes that passed (None: the whole effect)
    judged_with: dict[tuple, set[tuple]] = {}

    def base_of(effect: dict) -> set[tuple]:
        drives = acts_on([effect], [])
        return {_key(e) for e in kept if _key(e) != _key(effect) and _key(e) in passed
                and (acts_on([_passed_part(e, passed)], []) & drives).any()}

    def judge(effect: dict, base: set[tuple]) -> bool:
        judged_with[_key(effect)] = base
        drives = acts_on([effect], [])
        base_folds = [[_passed_part(e, passed) for e in fold if _key(e) in base] for fold in folds]
        with_folds = [base_fold + [e for e in fold if _key(e) == _key(effect)] for base_fold, fold in zip(base_folds, folds)]
        without = errors(base_folds)[0] if base else nominal_errors
        # A new block each round: a part refused before keeps the gain it was refused with.
        gain = effect.setdefault("evidence", {})["gain"] = {
            "horizon_s": GAIN_HORIZON, "what": WHAT, "alone": axis_gains(without, errors(with_folds)[0], drives, stretch, seed),
            "alone_with": sorted(":".join(k for k in key if k is not None) for key in base)}
        if _earned(gain["alone"]):
            passed[_key(effect)] = None
            return True
        lost, earned = _axes_by_gain(effect, ("alone",))
        if lost and earned:  # a limit whose other part gained: that part is what its drives are given from here on
            passed[_key(effect)] = earned
        return False

    failing = [effect for effect in _in_order(kept) if not judge(effect, base_of(effect))]
    changed = True
    while changed:
        changed = False
        for effect in list(failing):
            base = base_of(effect)
            if base != judged_with[_key(effect)] and judge(effect, base):
                failing.remove(effect)
                changed = True
    return failing


def _passed_part(effect: dict, passed: dict) -> dict:
    axes = passed[_key(effect)]
    return effect if axes is None else {**effect, "params": _only_axes(effect["params"], axes)}


def judge_gains(errors_of: ErrorsOf, effects: list[dict], fold_effects: list[list[dict]],
                seed: int = 0) -> tuple[list[dict], list[list[dict]], list[dict]]:
    """The effects that lower the held-out joint error of the drives they act on, alone and in the final set.

    Alone: each effect in turn (latency, speed limits, acceleration limits) against nominal plus the effects on the
    same drives that have passed this check before it: a rate limit behind a speed clip cannot gain on nominal drives
    that run past the true speed, and an effect that helps only beside one that fails alone is still judged against
    nominal. In the final set: the final set without it against the final set. Each effect gets evidence["gain"].
    While any fails, the one that fails worst (lowest interval bound against its error without it) is refused and the
    rest are judged again, alone and in the set without it. Returns the kept effects, their fold fits ([fold 0's,
    fold 1's]) and the refused effects (their gain and the reason)."""
    kept, folds, refused = list(effects), [list(f) for f in fold_effects], []
    errors = _memoised(errors_of)
    nominal_errors, stretch = errors([[], []])
    while kept:
        failing = _judge_alone(errors, kept, folds, nominal_errors, stretch, seed)
        final_errors, _ = errors(folds)
        for effect in kept:
            rest_errors, _ = errors([[e for e in fold if _key(e) != _key(effect)] for fold in folds])
            gain = effect["evidence"]["gain"]
            gain["in_final_set"] = axis_gains(rest_errors, final_errors, acts_on([effect], []), stretch, seed)
            if not _earned(gain["in_final_set"]) and all(effect is not f for f in failing):
                failing.append(effect)
        if not failing:
            break
        worst = min(failing, key=_worst)
        reason = (f"no held-out gain: the drop of the joint error {GAIN_HORIZON:g} s ahead on the drives it acts on has a "
                  "95 % interval that does not lie above zero, alone or in the final set")
        lost, earned = _axes_by_gain(worst, PARTS)
        if lost and earned:
            # A limit whose slide and rotation parts are judged apart (each acts on its own drives): the part without a
            # gain is refused, the part with one is judged again without it.
            part = {**worst, "params": _only_axes(worst["params"], lost),
                    "evidence": {**worst["evidence"], "reason": f"{reason} ({' and '.join(sorted(lost))} part)"}}
            refused.append(part)
            worst["params"] = _only_axes(worst["params"], set(AXES) - lost)
            folds = [_without_axes(fold, _key(worst), lost) for fold in folds]
            continue
        worst["evidence"]["reason"] = reason
        refused.append(worst)
        kept = [e for e in kept if e is not worst]
        folds = [[e for e in fold if _key(e) != _key(worst)] for fold in folds]
    return kept, folds, refused


def _worst(effect: dict) -> float:
    """The lowest bound of a drop's interval over the parts, as a share of the error without the effect."""
    bounds = [block["ci95_drop"][0] / max(block["without"], 1e-9)
              for part in PARTS for block in _judged(effect["evidence"]["gain"][part])]
    return min(bounds) if bounds else -np.inf


def _axes_by_gain(effect: dict, parts: tuple[str, ...]) -> tuple[set[str], set[str]]:
    """A speed or acceleration limit's axes (slide, rotate) whose judged intervals do not all lie above zero, and those
    whose do; a latency's parts are not judged apart (both empty)."""
    if effect["name"] == "rod_latency":
        return set(), set()
    lost, earned = set(), set()
    for axis in (a for a in AXES if a in effect["params"]):
        blocks = [block for part in parts for key, block in effect["evidence"]["gain"][part].items()
                  if key.startswith(axis) and block["ci95_drop"] is not None]
        if blocks:
            (earned if all(effect_gain.excludes_zero(b) for b in blocks) else lost).add(axis)
    return lost, earned


def _only_axes(params: dict, axes: set[str]) -> dict:
    return {k: v for k, v in params.items() if k not in AXES or k in axes}


def _without_axes(fold: list[dict], key: tuple, lost: set[str]) -> list[dict]:
    """A fold's effects with the `lost` axes taken from the effect of `key` (dropped where none is left)."""
    out = []
    for effect in fold:
        if _key(effect) == key:
            effect = {**effect, "params": _only_axes(effect["params"], set(AXES) - lost)}
            if not any(axis in effect["params"] for axis in AXES):
                continue
        out.append(effect)
    return out
