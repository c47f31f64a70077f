"""The twin beside the measurement: where each table's simulation parts from the measured ball.

The measured detections are cut into free stretches by the rule calibration fits on (tracks.analyse:
tracks, wall contacts, rolling segments). At each stretch the simulation restarts: the ball's state is
estimated from the stretch's first HISTORY s of rolling under each table's own dynamics (as the held-out
gain is measured, evaluate.choose_starts and estimate_states), and MuJoCo rolls it on that table's
ball-only model (mjsim.BallRollouts: same field, walls and effects) until the next restart on the same
track, the end of the track (the ball was picked up or left the field), or MAX_HORIZON. Nothing here is
fitted on what it is compared with: a prediction sees only the history before its restart.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from foos_core.table_geometry import TableGeometry

from .evaluate import HISTORY, Start, choose_starts, estimate_states
from .mjsim import BallRollouts, theta_of
from .tracks import Measured, on_field

MAX_HORIZON = 3.0  # s: a restart's prediction is shown at most this long
SAMPLE_DT = 0.005  # s between the predicted positions kept (interpolated to the frame times)
ALL_STARTS = 1_000_000  # choose_starts' cap, high enough to keep them all


@dataclass
class Restart:
    """Where the simulation starts again from the measurement, and until when its prediction is shown."""

    start: Start  # the track, the restart time t0 and the history its state is estimated from
    until: float  # s, bag time


@dataclass
class TablePrediction:
    """One table's predictions: per restart, times (bag clock) and ball centres (x, y), m."""

    label: str
    times: list[np.ndarray]
    xy: list[np.ndarray]


def restarts(measured: Measured, max_horizon: float = MAX_HORIZON) -> list[Restart]:
    """One restart per free stretch (rolling segment), HISTORY s into its rolling part; each is shown until the next
    restart on its track or the track's end."""
    starts = choose_starts(measured, ALL_STARTS)
    first: list[Start] = []
    for segment in measured.segments:
        on_segment = [s for s in starts if s.track == segment.track and segment.t[0] <= s.t0 <= segment.t[-1]]
        if on_segment:
            first.append(on_segment[0])
    first.sort(key=lambda s: s.t0)
    out = []
    for i, start in enumerate(first):
        track_end = float(measured.tracks[start.track][0][-1])
        following = [s.t0 for s in first[i + 1:] if s.track == start.track]
        until = min(following[0] if following else track_end, track_end, start.t0 + max_horizon)
        if until > start.t0:
            out.append(Restart(start, until))
    return out


def predict(restarts_: list[Restart], label: str, params: dict) -> TablePrediction:
    """The table's ball from every restart: state from the restart's history under this table's dynamics, then
    MuJoCo's ball-only model of the table."""
    if not restarts_:
        return TablePrediction(label, [], [])
    states = estimate_states([r.start for r in restarts_], [theta_of(params)] * len(restarts_))
    rollouts = BallRollouts([params])
    times, xy = [], []
    for restart, state in zip(restarts_, states):
        tau, positions = rollouts.positions([0], state[None], restart.until - restart.start.t0, SAMPLE_DT)
        times.append(restart.start.t0 + tau)
        xy.append(positions[0])
    return TablePrediction(label, times, xy)


def predicted_at(prediction: TablePrediction, geometry: TableGeometry, times: np.ndarray) -> np.ndarray:
    """The predicted ball centre (x, y) at each of times (bag clock), NaN where no restart's prediction is shown or
    the predicted ball has left the field (into a goal)."""
    times = np.atleast_1d(np.asarray(times, float))
    out = np.full((len(times), 2), np.nan)
    for tau, xy in zip(prediction.times, prediction.xy):
        shown = (times >= tau[0]) & (times <= tau[-1])
        if shown.any():
            out[shown] = np.stack([np.interp(times[shown], tau, xy[:, i]) for i in range(2)], axis=1)
    out[~on_field(geometry, np.nan_to_num(out, nan=np.inf))] = np.nan
    return out


def restarts_in(restarts_: list[Restart], begin: float, end: float) -> list[Restart]:
    """The restarts whose prediction is shown between begin and end (bag clock)."""
    return [r for r in restarts_ if r.until >= begin and r.start.t0 <= end]


__all__ = ["HISTORY", "MAX_HORIZON", "Restart", "TablePrediction", "predict", "predicted_at", "restarts", "restarts_in"]
