"""The rod drives' shaped velocity: each lane's (drive and candidate limits') model velocity at the encoder samples,
from the commands alone (rods: the model and why; the fit asks for hundreds of lanes at a time).

The servos' rate limiter and the jerk-limited drives' S-curves are recurrences over the command events. Their cost
grows with the command rate (60000 events in a 120 s game of 2 ms commands), so each lane is followed once: the
states at the events are kept by lane key (goals and limits: a delay only shifts the samples) and reused by later
calls of the same game (new_game() forgets them).
"""
from __future__ import annotations

import numpy as np

from foos_sim import scurve, scurve_lanes


def new_game() -> None:
    """Forget the lanes followed so far (a new game's events)."""
    RECURRENCES.__init__()
    RATE_LIMITERS.__init__()


def _recur(event_t: np.ndarray, goals: np.ndarray, accel: np.ndarray) -> np.ndarray:
    """The rate limiter's value at each event (K, L), for goals (K, L) holding from each event to the next:
    y_k+1 = max(min(goal_k, y_k + reach_k), y_k - reach_k), reach_k = accel x the gap to the next event.

    A loop over the events (each step depends on the one before) of four in-place ufuncs on rows of `out`: with 2 ms
    commands (60000 events in a 120 s game) the per-event overhead is the cost."""
    gaps = np.diff(event_t, append=event_t[-1])
    reach = gaps[:, None] * accel[None, :]
    out = np.zeros((len(event_t) + 1, goals.shape[1]))
    bound = np.empty(goals.shape[1])
    for k in range(len(event_t)):
        y, step, after = out[k], reach[k], out[k + 1]
        np.add(y, step, out=bound)
        np.minimum(goals[k], bound, out=after)
        np.subtract(y, step, out=bound)
        np.maximum(after, bound, out=after)
    return out[:-1]


class _RateLimiters:
    """The servos' rate limiters at the events of each team's commands, by lane key (goals' signature, acceleration),
    kept while they fit in CACHED_VALUES: the fit asks for the same lanes again and again (a latency sweep and the fit
    after each sweep: the recurrence does not depend on the delay; the held-out gain's predictions under fold limits
    that differ in one effect), and lanes that differ only in the fitting set they belong to share one. The least
    recently used lanes go first."""

    CACHED_VALUES = 40_000_000  # floats (320 MB): 660 lanes of a 120 s game's 2 ms commands

    def __init__(self):
        self.events: list[np.ndarray] = []
        self.lanes: dict[tuple, np.ndarray] = {}  # (events index, signature, acceleration) -> (K,), oldest first
        self.size = 0

    def _events_index(self, event_t: np.ndarray) -> int:
        for i, known in enumerate(self.events):
            if len(known) == len(event_t) and np.array_equal(known, event_t):
                return i
        self.events.append(event_t.copy())
        return len(self.events) - 1

    def follow(self, event_t: np.ndarray, goals: np.ndarray, accel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(U, K) the distinct lanes' values at the events (a lane a row: contiguous to keep), and (L,) each lane's row."""
        which = self._events_index(event_t)
        signature = np.random.default_rng(0).standard_normal(len(goals)) @ goals
        rows = [(which, s, a) for s, a in zip(signature.tolist(), accel.tolist())]
        distinct = list(dict.fromkeys(rows))
        first = {row: i for i, row in reversed(list(enumerate(rows)))}
        fresh = [row for row in distinct if row not in self.lanes]
        if fresh:
            picks = np.array([first[row] for row in fresh], dtype=int)
            computed = _recur(event_t, goals[:, picks], accel[picks]).T
            for j, row in enumerate(fresh):
                self.lanes[row] = computed[j].copy()  # a copy: a view would hold all of `computed`
                self.size += len(event_t)
        for row in distinct:
            self.lanes[row] = self.lanes.pop(row)  # now the most recently used
        values = np.stack([self.lanes[row] for row in distinct])
        while self.size > self.CACHED_VALUES and self.lanes:
            self.size -= len(self.lanes.pop(next(iter(self.lanes))))
        index = {row: j for j, row in enumerate(distinct)}
        return values, np.array([index[row] for row in rows], dtype=int)


RATE_LIMITERS = _RateLimiters()


def _event_index(event_t: np.ndarray, sample_t: np.ndarray, shift: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(L, N) each: sample_t - shift per lane, the last event at or before it (clamped to 0), and whether there is one.
    One search per distinct shift (lanes of a sweep of the speed or acceleration share a handful of delays)."""
    shifted = sample_t[None, :] - shift[:, None]
    distinct, inverse = np.unique(shift, return_inverse=True)
    found = np.stack([np.searchsorted(event_t, sample_t - s, side="right") for s in distinct]) - 1
    k = found[inverse.ravel()]
    valid = k >= 0
    return shifted, np.maximum(k, 0), valid


class _Recurrences:
    """The S-curves' states at the events of lanes already followed (a fit asks for the same lanes again: a
    component held while another is swept, the same candidates in the next sweep and subset), by lane key. The lanes
    followed in one call make a block: (velocity, acceleration, goals), each (lanes, K), a lane a row, so that a call
    hands the compiled evaluation row numbers, not (K, lanes) copies (two of 60000 x 600 floats per call with 2 ms
    commands).

    Blocks, not one array grown by half when full: the growth copied every lane kept so far each time and held the old
    and the new array at once: on the robot bench's trial 20 (938 Hz encoders, 10 ms commands) 6.3 of the calibration's
    143 profiled s, and a peak of 2.5 GB where blocks need 1.7 (robot-nominal-7); trial 18 (2 ms commands) reached 9 GB."""

    def __init__(self):
        self.events = None
        self.rows: dict[tuple, tuple[int, int]] = {}  # lane key -> (block, row in it)
        self.blocks: list[tuple[np.ndarray, np.ndarray, np.ndarray]] = []

    def follow(self, event_t, keys, goals, accel, jerk) -> tuple[np.ndarray, np.ndarray]:
        """(L,) each lane's block and (L,) its row there, following the lanes not seen before (keys distinct; goals
        (K, L); accel, jerk (L,))."""
        if self.events is None or len(self.events) != len(event_t) or not np.array_equal(self.events, event_t):
            self.events, self.rows, self.blocks = event_t.copy(), {}, []
        keyed = [tuple(k) for k in keys.tolist()]
        missing = [i for i, key in enumerate(keyed) if key not in self.rows]
        if missing:
            v, a = scurve.follow(event_t, goals[:, missing], accel[missing], jerk[missing])
            block = len(self.blocks)
            self.blocks.append((np.ascontiguousarray(v.T), np.ascontiguousarray(a.T), np.ascontiguousarray(goals[:, missing].T)))
            for j, i in enumerate(missing):
                self.rows[keyed[i]] = (block, j)
        places = np.array([self.rows[key] for key in keyed], dtype=np.int64).reshape(-1, 2)
        return places[:, 0], places[:, 1]


RECURRENCES = _Recurrences()


def _s_curve_velocity(event_t, goals, sample_t, delay, accel, jerk, acceleration=False):
    """shaped_velocity on the jerk-limited drives: each lane's S-curve (foos_sim.scurve) through its goals."""
    # Lanes with the same goals and limits (candidates of a latency, which only shifts the samples) share one
    # recurrence over the events: the goals compared through a fixed random projection.
    signature = np.random.default_rng(0).standard_normal(len(goals)) @ goals
    lanes = len(signature)
    accel, jerk, delay = (np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (lanes,))) for x in (accel, jerk, delay))
    keys = np.stack([signature, accel, jerk], axis=1)
    _, first, inverse = np.unique(keys, axis=0, return_index=True, return_inverse=True)
    block, row = (x[inverse.ravel()] for x in RECURRENCES.follow(event_t, keys[first], goals[:, first], accel[first], jerk[first]))
    sample_t = np.ascontiguousarray(sample_t, dtype=float)
    # Each lane's S-curve from its last event's state to every sample, compiled (scurve_lanes.sampled; the same bits as
    # scurve.advance on (lanes x samples) arrays, about half of a robot-table trial's calibration in numpy), a block at
    # a time (each lane on its own: the same bits however the lanes are grouped).
    used = np.unique(block)
    if len(used) == 1:
        velocity, accel_rows, goal_rows = RECURRENCES.blocks[int(used[0])]
        v, a = scurve_lanes.sampled(RECURRENCES.events, velocity, accel_rows, goal_rows, row, sample_t, delay, accel, jerk,
                                    acceleration)
        return (v, a) if acceleration else v
    v = np.empty((lanes, len(sample_t)))
    a = np.empty((lanes, len(sample_t))) if acceleration else None
    for b in used:
        lane = np.flatnonzero(block == b)
        velocity, accel_rows, goal_rows = RECURRENCES.blocks[int(b)]
        v_block, a_block = scurve_lanes.sampled(RECURRENCES.events, velocity, accel_rows, goal_rows, row[lane], sample_t,
                                                delay[lane], accel[lane], jerk[lane], acceleration)
        v[lane] = v_block
        if acceleration:
            a[lane] = a_block
    return (v, a) if acceleration else v


def shaped_velocity(event_t, commands, sample_t, delay, speed, accel, lag, jerk=None, acceleration=False):
    """(L, N): the model's velocity at sample_t for L lanes (commands (K, L); delay, speed, accel, lag, jerk (L,);
    jerk None: the servos' rate limiter, else the jerk-limited drives' S-curves, and with `acceleration` their
    setpoints' acceleration too)."""
    goals = np.clip(commands, -speed, speed)
    if jerk is not None:
        return _s_curve_velocity(event_t, goals, sample_t, np.asarray(delay + lag, dtype=float), accel, jerk, acceleration)
    accel = np.broadcast_to(np.asarray(accel, dtype=float), goals.shape[1:])
    y, column = RATE_LIMITERS.follow(event_t, goals, accel)
    shifted, k, valid = _event_index(event_t, sample_t, np.broadcast_to(np.asarray(delay + lag, dtype=float), goals.shape[1:]))
    lanes = np.arange(goals.shape[1])[:, None]
    y0, goal = y[column[:, None], k], goals[k, lanes]
    reach = np.maximum(shifted - event_t[k], 0.0)
    reach *= accel[:, None]
    goal -= y0
    np.minimum(goal, reach, out=goal)
    np.negative(reach, out=reach)
    np.maximum(goal, reach, out=goal)
    goal += y0
    goal *= valid
    return goal
