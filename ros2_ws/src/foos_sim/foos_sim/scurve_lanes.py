"""scurve.plan and scurve.evaluate compiled one lane at a time (numba), for the long recurrences of a calibration fit,
and the fast physics' setpoints (ProfileDrives: a re-plan and the setpoint blocks, _in_phases below).

A fit follows hundreds of lanes through every command event of a game (60000 events of 2 ms commands in 120 s) and
then evaluates each lane at every fitting sample. In numpy that is a pass of about 60 ufuncs per event over a few
hundred lanes, then the same 60 passes over (lanes x samples) arrays of several million: 85-344 s of a robot-table
trial's calibration (calibration-2026-11-28-robot-cpu-6.md). Here each lane's state stays in registers.

The arithmetic is scurve.plan's and scurve.evaluate's, operation for operation and in the same order (no fastmath, so
no fused multiply-adds or reassociation): the results are bit-identical to the numpy functions', which
tests/foos_sim/test_scurve_lanes.py checks. A change to the formulas there must be made here too; that test fails
until it is.

cache=True keeps the compiled code between processes in __pycache__ beside this file, or, where that is not
writable (an installed package), in numba's per-user cache directory; without a cache the first call compiles
(about 2-3 s, measured in the log above).

The fast physics' generator (foos_sim.drive_profiles.ProfileDrives) holds its plan of the 16 drives packed as the
rows of one (PLAN_ROWS, 16) array (one argument: numba's dispatch costs about 0.45 us an array argument, a numpy
pass on 16 values 1-3 us, and a setpoint block was ten such passes). Its velocity within the phases (_in_phases) is
the one rule: scurve.evaluate's closed form regrouped (v0 + a0 e1 + J1 e1^2 / 2 + a1 (e2 + e3) + J3 e3^2 / 2), which
tests/foos_sim/test_drive_profiles.py checks against scurve.evaluate; the same operations in the same order as the
numpy it replaced (docs/measurements/sim-2026-11-28-drive-speed-7.md: bit-identical trajectories).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

V0, A0, JERK1, T1, T2, JERK3, T3, TARGET = range(8)  # the rows of a packed plan (ProfileDrives)
PLAN_ROWS = 8
SETTLED = 1e-9  # scurve.SETTLED (not imported: scurve imports this module lazily, and the value is the rule's)


@njit(cache=True, inline="always")
def _sign(x: float) -> float:
    if x > 0.0:
        return 1.0
    if x < 0.0:
        return -1.0
    return x  # 0.0, -0.0 or nan, as np.sign


@njit(cache=True, inline="always")
def _max(x: float, y: float) -> float:
    return x if (x >= y or x != x) else y  # np.maximum: nan propagates


@njit(cache=True, inline="always")
def _min(x: float, y: float) -> float:
    return x if (x <= y or x != x) else y  # np.minimum


@njit(cache=True)
def _plan(v0, a0, target, accel, jerk):
    """scurve.plan for one lane: (jerk1, t1, t2, jerk3, t3)."""
    v_stop = v0 + a0 * abs(a0) / (2.0 * jerk)
    beyond = target - v_stop
    s = _sign(beyond)
    brake_only = abs(beyond) <= SETTLED
    if brake_only:
        s = 1.0
    gain = s * (target - v0)
    a_start = s * a0
    peak = math.sqrt(_max(jerk * gain + 0.5 * a_start * a_start, 0.0))
    capped = peak > accel
    if capped:
        peak = accel
    t1 = abs(peak - a_start) / jerk
    t3 = peak / jerk
    gained = (a_start + peak) * t1 / 2.0 + peak * t3 / 2.0
    t2 = _max(gain - gained, 0.0) / _max(peak, 1e-300) if capped else 0.0
    jerk1 = s * _sign(peak - a_start) * jerk
    if brake_only:
        t1 = abs(a0) / jerk
        jerk1 = -_sign(a0) * jerk
        t2 = 0.0
        t3 = 0.0
    return jerk1, t1, t2, -s * jerk, t3


@njit(cache=True)
def _evaluate(v0, a0, target, jerk1, t1, t2, jerk3, t3, elapsed):
    """scurve.evaluate's (velocity, acceleration) for one lane's plan `elapsed` after its start."""
    remaining = elapsed - t1 - t2 - t3  # scurve.evaluate's `remaining` after the three phases, the same subtractions
    if remaining >= 0.0:
        return target, 0.0  # past the profile (most samples of a settled lane): the phases' sums are not needed
    v = v0 + 0.0 * elapsed
    a = a0 + 0.0 * elapsed
    remaining = elapsed
    e = _min(_max(remaining, 0.0), t1)
    v = v + (a + jerk1 * e / 2.0) * e
    a = a + jerk1 * e
    remaining = remaining - t1
    e = _min(_max(remaining, 0.0), t2)
    v = v + (a + 0.0 * e / 2.0) * e
    a = a + 0.0 * e
    remaining = remaining - t2
    e = _min(_max(remaining, 0.0), t3)
    v = v + (a + jerk3 * e / 2.0) * e
    a = a + jerk3 * e
    return v, a


@njit(cache=True)
def _advance(v0, a0, target, accel, jerk, elapsed):
    """scurve.advance for one lane: (velocity, acceleration) `elapsed` after (v0, a0)."""
    jerk1, t1, t2, jerk3, t3 = _plan(v0, a0, target, accel, jerk)
    return _evaluate(v0, a0, target, jerk1, t1, t2, jerk3, t3, elapsed)


@njit(cache=True)
def follow(event_t, goal_rows, accel, jerk):
    """scurve.follow lane by lane: (velocity, acceleration) (L, K) at each event for goal_rows (L, K) (a lane a row:
    read and written in order; a (K, L) layout costs a cache miss per event and array); accel, jerk (L,)."""
    n_lanes, n_events = goal_rows.shape
    v_out = np.empty((n_lanes, n_events))
    a_out = np.empty((n_lanes, n_events))
    for j in range(n_lanes):
        v = 0.0
        a = 0.0
        for k in range(n_events):
            v_out[j, k] = v
            a_out[j, k] = a
            gap = (event_t[k + 1] - event_t[k]) if k + 1 < n_events else 0.0  # np.diff(event_t, append=event_t[-1])
            v, a = _advance(v, a, goal_rows[j, k], accel[j], jerk[j], gap)
    return v_out, a_out


@njit(cache=True)
def sampled(event_t, v_rows, a_rows, goal_rows, row, sample_t, shift, accel, jerk, with_acceleration):
    """Per lane l (L) and sample n (N): the S-curve's (velocity, acceleration) at sample_t[n] - shift[l], from the state
    at the last event at or before it (row[l] of v_rows, a_rows, goal_rows (R, K)); 0 before the first event.
    As drive_shaping did in numpy: advance(state at event k, goal k, elapsed = max(shifted - event_t[k], 0)) x valid.
    Samples in ascending time (else each is searched for) share their event's plan: a plan costs a square root and
    four divisions, the evaluation only multiplications."""
    n_lanes = len(row)
    n_samples = len(sample_t)
    v_out = np.empty((n_lanes, n_samples))
    a_out = np.empty((n_lanes, n_samples) if with_acceleration else (0, 0))
    ascending = True
    for n in range(1, n_samples):
        if not sample_t[n] >= sample_t[n - 1]:
            ascending = False
    n_events = len(event_t)
    for lane in range(n_lanes):
        u = row[lane]
        k = -1  # the last event at or before the sample
        planned = -2  # the event whose plan is held
        jerk1 = t1 = t2 = jerk3 = t3 = 0.0
        for n in range(n_samples):
            shifted = sample_t[n] - shift[lane]
            if ascending:
                while k + 1 < n_events and event_t[k + 1] <= shifted:
                    k += 1
            else:
                k = np.searchsorted(event_t, shifted, side="right") - 1
            valid = k >= 0
            at = k if valid else 0
            if at != planned:
                jerk1, t1, t2, jerk3, t3 = _plan(v_rows[u, at], a_rows[u, at], goal_rows[u, at], accel[lane], jerk[lane])
                planned = at
            elapsed = _max(shifted - event_t[at], 0.0)
            v, a = _evaluate(v_rows[u, at], a_rows[u, at], goal_rows[u, at], jerk1, t1, t2, jerk3, t3, elapsed)
            scale = 1.0 if valid else 0.0
            v_out[lane, n] = v * scale
            if with_acceleration:
                a_out[lane, n] = a * scale
    return v_out, a_out


@njit(cache=True, inline="always")
def _in_phases(plan, lane, elapsed):
    """A packed plan's lane `elapsed` after its start: (velocity before the profile ends, e1, e3, done, a1), each e the
    time spent in its phase so far and a1 the acceleration through phases 2 and 3."""
    v0, a0, jerk1, t1 = plan[V0, lane], plan[A0, lane], plan[JERK1, lane], plan[T1, lane]
    e1 = _min(_max(elapsed, 0.0), t1)
    rest = elapsed - t1
    e2 = _min(_max(rest, 0.0), plan[T2, lane])
    rest = rest - plan[T2, lane]
    t3 = plan[T3, lane]
    e3 = _min(_max(rest, 0.0), t3)
    a1 = a0 + jerk1 * t1
    v = ((0.5 * jerk1) * e1 + a0) * e1 + v0
    v = v + (e2 + e3) * a1
    v = v + ((0.5 * plan[JERK3, lane]) * e3) * e3
    return v, e1, e3, rest >= t3, a1


@njit(cache=True)
def state(plan, elapsed):
    """(velocity, acceleration) (2, lanes) of a packed plan `elapsed` after its start."""
    lanes = plan.shape[1]
    out = np.empty((2, lanes))
    for lane in range(lanes):
        v, e1, e3, done, a1 = _in_phases(plan, lane, elapsed)
        if done:
            out[0, lane], out[1, lane] = plan[TARGET, lane], 0.0
        else:
            out[0, lane] = v
            out[1, lane] = plan[A0, lane] + plan[JERK1, lane] * e1 if e1 < plan[T1, lane] else a1 + plan[JERK3, lane] * e3
    return out


@njit(cache=True)
def replan(plan, elapsed, goal, limits):
    """Plan again in place from the packed plan's state `elapsed` after its start towards `goal`, within limits
    (acceleration, jerk) (2, lanes); the time from then until every lane holds its goal."""
    now = state(plan, elapsed)
    longest = -np.inf
    for lane in range(plan.shape[1]):
        v0, a0, target = now[0, lane], now[1, lane], goal[lane]
        jerk1, t1, t2, jerk3, t3 = _plan(v0, a0, target, limits[0, lane], limits[1, lane])
        plan[V0, lane], plan[A0, lane], plan[JERK1, lane], plan[T1, lane] = v0, a0, jerk1, t1
        plan[T2, lane], plan[JERK3, lane], plan[T3, lane], plan[TARGET, lane] = t2, jerk3, t3, target
        duration = t1 + t2 + t3
        if duration > longest:
            longest = duration
    return longest


@njit(cache=True)
def velocities(plan, base, offsets, scale, lead, out, start, end):
    """out[r] for r in [start, end): each lane's velocity at (base + offsets[r] scale) + lead[lane] after the plan's
    start (the setpoints at a block's step middles, or at a cut step's sub-step middles)."""
    for r in range(start, end):
        at = base + offsets[r] * scale
        for lane in range(plan.shape[1]):
            v, _, _, done, _ = _in_phases(plan, lane, at + lead[lane])
            out[r, lane] = plan[TARGET, lane] if done else v
