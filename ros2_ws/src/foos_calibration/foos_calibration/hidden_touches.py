"""Touches the camera alone did not see: a rolling segment better explained as two rolls than as one is cut there.

Without joint states the figure contacts come from sudden velocity changes near a rod line
(figure_contacts.RodLines), judged over short windows; a touch that turns the ball a little stays inside a
rolling segment and spoils every fit that uses it. On a generated game (tilted 4 mrad, 60 s) filmed alone, 16 %
of the segments the rod lines left had residuals over twice the camera noise about a nominal roll, against none
with the figures posed from the encoders, and the tilt's held-out drop disagreed between the folds (+94 and
-203 noise variances), so it was not named.

Over a whole segment a change point is far easier to see than over a window. A touch is an impulse: the
ball goes on from where it was with another velocity. So each segment is fitted, per axis, as a roll with a
constant acceleration (position, velocity, acceleration: what rolling resistance, a tilt or slow damping give
over the few tenths of a second a segment lasts) and, at each candidate instant, as the same roll plus a jump
of velocity there. Both are linear least squares; where the best jump lowers the squared residual by more than
SPLIT_DROP noise variances, the segment is cut there and each piece is tried again. Without a touch the drop is
the largest of many chi-squared values with two degrees of freedom: on simulated rolls of 0.4-1.5 s with 1.5 mm
of noise, flat or tilted up to 10 mrad, a median of 3-4 and at most 11 noise variances in 10 seeds; a jump of
0.1 m/s in the middle of a 0.6 s roll gives 41-56 (0.05 m/s: 16-22, left whole).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from .tracks import MIN_SEGMENT, Segment

SPLIT_DROP = 30.0    # noise variances: the drop of the squared residual that cuts a segment (selection's threshold)
MIN_PIECE = 0.1      # s: the least roll either side of a candidate jump
CANDIDATE_STEP = 2   # samples between candidate jumps
GUARD = 3            # samples left out either side of a cut: the touch itself
MAX_DEPTH = 3        # cuts tried within one segment, one after another


def _pieces(segment: Segment, k: int) -> tuple[Segment, Segment]:
    first = replace(segment, t=segment.t[:k - GUARD], xy=segment.xy[:k - GUARD])
    second = replace(segment, t=segment.t[k + GUARD:], xy=segment.xy[k + GUARD:], slide=False, slip_guess=None)
    return first, second


def _sse(design: np.ndarray, xy: np.ndarray) -> float:
    """Squared residual of both axes about their least-squares fit on the columns of `design`."""
    coefficients, *_ = np.linalg.lstsq(design, xy, rcond=None)
    residual = xy - design @ coefficients
    return float(np.sum(residual * residual))


def best_split(segment: Segment, noise: float) -> tuple[int, float] | None:
    """(sample index, drop in noise variances) of the velocity jump that lowers the squared residual most, or None
    when no candidate leaves MIN_PIECE either side."""
    t = segment.t - segment.t[0]
    candidates = [k for k in range(GUARD, len(t) - GUARD, CANDIDATE_STEP)
                  if t[k] >= MIN_PIECE and t[-1] - t[k] >= MIN_PIECE]
    if not candidates:
        return None
    roll = np.stack([np.ones_like(t), t, 0.5 * t * t], axis=1)
    xy = segment.xy - segment.xy[0]
    whole = _sse(roll, xy)
    split = [_sse(np.column_stack([roll, np.maximum(t - t[k], 0.0)]), xy) for k in candidates]
    i = int(np.argmin(split))
    return candidates[i], (whole - split[i]) / (noise * noise)


def split_hidden_touches(segments: list[Segment], noise: float) -> tuple[list[Segment], int]:
    """The segments cut wherever a velocity jump explains the data by SPLIT_DROP noise variances more than one
    smooth roll, pieces shorter than MIN_SEGMENT dropped; and how many cuts were made."""
    out, cuts = [], 0
    work = [(s, 0) for s in segments]
    while work:
        segment, depth = work.pop()
        found = best_split(segment, noise) if depth < MAX_DEPTH else None
        if found is None or found[1] < SPLIT_DROP:
            out.append(segment)
            continue
        cuts += 1
        for piece in _pieces(segment, found[0]):
            if piece.t[-1] - piece.t[0] >= MIN_SEGMENT:
                work.append((piece, depth + 1))
    out.sort(key=lambda s: s.t[0])
    return out, cuts
