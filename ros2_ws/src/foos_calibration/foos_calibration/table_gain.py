"""The gain rule for the rolling table effects: one is named only if it lowers the ball's held-out error on the rolling
data it touches, alone (nominal -> nominal + it) and in the final set (the set without it -> the set).

Held out: the segments of each fold are fitted (their initial states only, every parameter held) under the
parameters fitted on the other fold (selection.fold_theta), as the selection's own evidence is. The error is
the RMS distance between the detections and that fit over the samples of the pieces (PIECE long: the
held-out stretches) the effect touches: those where its path with and without it (from the same states)
part by more than TOUCH (a tilt or a loss touches every piece, a dent those that roll near it). The drop is
that RMS without it less with it; its 95 % interval resamples whole pieces (effect_gain.drop_interval).
The wall and figure restitutions are judged by their own replays (bounces, figure_bounces).
"""
from __future__ import annotations

from typing import Callable

import numpy as np

from . import effect_gain
from .fitting import SegmentBatch, fit_states
from .tracks import Segment

PIECE = 0.25  # s: held-out stretches of a segment
# s: with a camera alone, the figure contacts that cut the tracks are inferred from the ball's path, and a touch that
# hardly turns the ball stays inside a segment; the gain is judged only on free stretches this long, where one is
# unlikely to hide (issue 27 item 5).
CAMERA_ONLY_MIN_STRETCH = 0.5
TOUCH = 0.0005  # m: an effect touches a piece whose paths with and without it part by more than this
# names (a tuple of named rolling effects) -> [theta fitted on fold 0, theta fitted on fold 1] with only those effects
Build = Callable[[tuple[str, ...]], list[np.ndarray]]


class HeldOutPieces:
    """Each fold's segments fitted under the other fold's parameters: per-piece errors and paths, cached by model."""

    def __init__(self, segments: list[Segment]):
        self.folds = [[s for s in segments if s.fold == k] for k in (0, 1)]
        self.batches = [SegmentBatch(f) if f else None for f in self.folds]
        self.cache: dict[tuple, list] = {}

    def _pieces(self, batch: SegmentBatch) -> np.ndarray:
        return (batch.tau[batch.seg_of, batch.sample_of] // PIECE).astype(int) + 10_000 * batch.seg_of

    def errors(self, key: tuple, thetas: list[np.ndarray]) -> list[tuple]:
        """Per fold j: (states fitted under thetas[1 - j], per-sample residual distance (m))."""
        if key not in self.cache:
            out = []
            for j, batch in enumerate(self.batches):
                if batch is None:
                    out.append(None)
                    continue
                f = fit_states(batch, thetas[1 - j])
                r = batch.residual_of(batch.predict(f.states, np.tile(thetas[1 - j], (batch.n, 1)))).reshape(-1, 2)
                out.append((f.states, np.hypot(r[:, 0], r[:, 1])))
            self.cache[key] = out
        return self.cache[key]

    def drop(self, without: tuple, with_: tuple, seed: int) -> dict:
        """The drop of the held-out piece error from model `without` to `with_` ((key, fold thetas) each), on the pieces
        the change touches."""
        before, after = self.errors(*without), self.errors(*with_)
        mse_without, mse_with, samples, groups = [], [], [], []
        for j, batch in enumerate(self.batches):
            if batch is None:
                continue
            states, d_without = before[j]
            _, d_with = after[j]
            theta_with = with_[1][1 - j]
            theta_without = without[1][1 - j]
            path_with = batch.predict(states, np.tile(theta_with, (batch.n, 1)))[batch.seg_of, batch.sample_of]
            path_without = batch.predict(states, np.tile(theta_without, (batch.n, 1)))[batch.seg_of, batch.sample_of]
            parted = np.hypot(*(path_with - path_without).T) > TOUCH
            pieces = self._pieces(batch) + 10_000_000 * j
            for p in np.unique(pieces[parted]):
                m = pieces == p
                mse_without.append(np.mean(d_without[m] ** 2))
                mse_with.append(np.mean(d_with[m] ** 2))
                samples.append(m.sum())
                groups.append(p)
        block = effect_gain.drop_interval(np.array(mse_without), np.array(mse_with), np.array(groups, dtype=int), seed, 1000.0,
                                          weights=np.array(samples, dtype=float))
        return {"touched_pieces": block.pop("stretches"), **{k: v for k, v in block.items() if k != "starts"}}


def long_stretches(segments: list[Segment], min_duration: float = CAMERA_ONLY_MIN_STRETCH) -> list[Segment]:
    """The segments that last at least `min_duration` seconds."""
    return [s for s in segments if s.t[-1] - s.t[0] >= min_duration]


def judge(segments: list[Segment], build: Build, names: list[str], seed: int = 0,
          progress: Callable[[str], None] = lambda message: None, min_duration: float = 0.0) -> tuple[list[str], dict, dict]:
    """The named rolling effects that gain, alone and in the final set: (kept names, {name: gain}, {name: refused
    evidence with the reason}). While any fails, the one that fails worst is refused and the rest judged again.
    Only segments of at least `min_duration` seconds are held out (CAMERA_ONLY_MIN_STRETCH for a camera alone)."""
    kept, refused, gains = list(names), {}, {}
    segments = long_stretches(segments, min_duration) if min_duration > 0 else segments
    held = HeldOutPieces(segments)
    if any(b is None for b in held.batches):
        return [], {}, {n: {"reason": "no held-out gain: too few rolls for held-out folds"} for n in kept}

    def model(subset):
        key = tuple(sorted(subset))
        return key, build(key)

    while kept:
        progress(f"held-out gain of {' + '.join(kept)}, each alone and in the final set")
        failing = []
        for name in kept:
            gain = {"what": "the ball's RMS error (mm) about the held-out fit over the pieces of segments it touches",
                    "piece_s": PIECE, "min_stretch_s": min_duration,
                    "alone": held.drop(model(()), model((name,)), seed),
                    "in_final_set": held.drop(model([n for n in kept if n != name]), model(kept), seed)}
            gains[name] = gain
            if not all(effect_gain.excludes_zero(gain[part]) for part in ("alone", "in_final_set")):
                worst = min((gain[p]["ci95_drop"][0] / max(gain[p]["without"], 1e-9) if gain[p]["ci95_drop"] else -np.inf)
                            for p in ("alone", "in_final_set"))
                failing.append((worst, name))
        if not failing:
            break
        _, worst = min(failing)
        refused[worst] = {"gain": gains.pop(worst),
                          "reason": "no held-out gain: the drop of the ball's error on the rolling data it touches has a "
                                    "95 % interval that does not lie above zero (or too few pieces to tell), alone or in "
                                    "the final set"}
        kept.remove(worst)
    return kept, gains, refused
