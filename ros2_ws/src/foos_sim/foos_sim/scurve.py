"""Jerk-limited velocity profiles (S-curves): how a servo drive follows a velocity command.

A drive's trajectory generator takes its velocity from where it is (velocity v0, acceleration a0) to the
target velocity in the least time with |acceleration| <= A and |jerk| <= J, as robot drives do online:

    jerk +J (or -J) until the acceleration peaks, hold the peak (only if it reaches A), jerk back to zero.

The peak ap follows from the velocity to gain G (in the direction of the target; the velocity the drive
reaches if it just brought its acceleration to zero is v0 + a0 |a0| / 2J):

    phase 1: a0 -> ap in |ap - a0| / J, gains (a0 + ap) |ap - a0| / 2J
    phase 3: ap -> 0  in ap / J,        gains ap^2 / 2J
    ap^2 = J G + a0^2 / 2 with no plateau; else ap = A and the plateau takes the rest at A.

Everything is elementwise numpy, so one call plans thousands of lanes of a calibration fit; the same formulas compiled
one lane at a time (scurve_lanes) follow the calibration's long recurrences and give the fast physics its setpoints.
A plan is exact: evaluating it at any time gives the profile's state there, and planning
again from that state towards the same target gives the same trajectory (no drift from re-planning).

Why not `ruckig` (PyPI 0.19.4, whose velocity interface computes the same time-optimal profiles): it steps
its state at a fixed cycle, one call per control cycle for all axes; on the 500 Hz physics that cost 26 us
a step for 16 axes (a fast physics step costs about 20 us), it cannot be sampled at the reference's chunk
times or vectorised over a calibration fit's lanes. A velocity target needs only the closed form above.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SETTLED = 1e-9  # velocity (m/s or rad/s) below which a drive is at its target: no motion is planned


@dataclass(frozen=True)
class Profile:
    """Per lane: the start state, the three phases (jerk, duration) and the target velocity."""

    v0: np.ndarray
    a0: np.ndarray
    jerk1: np.ndarray
    t1: np.ndarray
    t2: np.ndarray
    jerk3: np.ndarray
    t3: np.ndarray
    target: np.ndarray
    @property
    def duration(self) -> np.ndarray:
        """Time from the plan's start until each lane holds its target."""
        return self.t1 + self.t2 + self.t3


def plan(v0, a0, target, accel, jerk) -> Profile:
    """The time-optimal jerk-limited profile from (v0, a0) to `target` with zero acceleration there."""
    v0, a0, target = (np.asarray(x, dtype=float) for x in (v0, a0, target))
    accel, jerk = np.asarray(accel, dtype=float), np.asarray(jerk, dtype=float)
    if not (v0.shape == a0.shape == target.shape == accel.shape == jerk.shape):  # (broadcasting costs a re-plan 10 us)
        v0, a0, target, accel, jerk = np.broadcast_arrays(v0, a0, target, accel, jerk)
    # Where braking the acceleration at once would leave the drive; the target lies beyond it (s = +1) or short.
    v_stop = v0 + a0 * np.abs(a0) / (2.0 * jerk)
    beyond = target - v_stop
    s = np.sign(beyond)
    brake_only = np.abs(beyond) <= SETTLED
    braking = np.count_nonzero(brake_only) > 0  # rare (a command equal to where braking leads): its passes only then
    if braking:
        s = np.where(brake_only, 1.0, s)
    gain = s * (target - v0)  # velocity to gain along s
    a_start = s * a0
    peak = np.sqrt(np.maximum(jerk * gain + 0.5 * a_start * a_start, 0.0))
    capped = peak > accel
    peak = np.where(capped, accel, peak)
    t1 = np.abs(peak - a_start) / jerk
    t3 = peak / jerk
    gained = (a_start + peak) * t1 / 2.0 + peak * t3 / 2.0
    t2 = np.where(capped, np.maximum(gain - gained, 0.0) / np.maximum(peak, 1e-300), 0.0)
    jerk1 = s * np.sign(peak - a_start) * jerk
    if braking:
        # Target already where braking leads: only bring the acceleration to zero.
        t1 = np.where(brake_only, np.abs(a0) / jerk, t1)
        jerk1 = np.where(brake_only, -np.sign(a0) * jerk, jerk1)
        t2 = np.where(brake_only, 0.0, t2)
        t3 = np.where(brake_only, 0.0, t3)
    return Profile(v0=v0, a0=a0, jerk1=jerk1, t1=t1, t2=t2, jerk3=-s * jerk, t3=t3, target=target)


def evaluate(profile: Profile, elapsed) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(velocity, acceleration, distance) `elapsed` seconds after the plan's start (broadcast against the
    lanes: elapsed of shape (k, 1) gives k rows). Past the profile the target holds exactly."""
    elapsed = np.asarray(elapsed, dtype=float)
    v, a, d = profile.v0 + 0.0 * elapsed, profile.a0 + 0.0 * elapsed, 0.0 * (profile.v0 + elapsed)
    remaining = elapsed
    for j, duration in ((profile.jerk1, profile.t1), (0.0, profile.t2), (profile.jerk3, profile.t3)):
        e = np.clip(remaining, 0.0, duration)
        d = d + (v + (a / 2.0 + j * e / 6.0) * e) * e
        v = v + (a + j * e / 2.0) * e
        a = a + j * e
        remaining = remaining - duration
    done = remaining >= 0.0
    beyond = np.maximum(remaining, 0.0)
    d = d + profile.target * beyond
    v = np.where(done, profile.target, v)
    a = np.where(done, 0.0, a)
    return v, a, d


def advance(v0, a0, target, accel, jerk, elapsed) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(velocity, acceleration, distance) `elapsed` after (v0, a0), heading for `target` (plan, then evaluate)."""
    return evaluate(plan(v0, a0, target, accel, jerk), elapsed)


def follow(event_t: np.ndarray, goals: np.ndarray, accel, jerk) -> tuple[np.ndarray, np.ndarray]:
    """The S-curve's (velocity, acceleration) at each event (K, L), for goals (K, L) that each hold from their
    event to the next, starting from rest before the first (a recurrence over the events only): advance() from event
    to event, compiled lane by lane (scurve_lanes; bit-identical). A numpy pass per event was a quarter of a profiled robot-table
    calibration with 20 ms commands (calibration-2026-11-28-robot-cpu-6.md)."""
    # numba's import (0.5 s) only where a fit needs it, not in the physics that imports this module
    from .scurve_lanes import follow as follow_lanes

    goal_rows = np.ascontiguousarray(np.asarray(goals, dtype=float).T)  # a lane a row
    lanes = goal_rows.shape[0]
    accel, jerk = (np.ascontiguousarray(np.broadcast_to(np.asarray(x, dtype=float), (lanes,))) for x in (accel, jerk))
    v_rows, a_rows = follow_lanes(np.ascontiguousarray(event_t, dtype=float), goal_rows, accel, jerk)
    return v_rows.T, a_rows.T  # (K, L) views: each lane's column is contiguous


def follow_numpy(event_t: np.ndarray, goals: np.ndarray, accel, jerk) -> tuple[np.ndarray, np.ndarray]:
    """follow() in numpy, as it was before it was compiled: advance() from event to event, one numpy pass over the
    lanes per event. The reference whose bits scurve_lanes.follow must give (tests/foos_sim/test_scurve_lanes.py) and
    the "before" of `bench_calibration --lanes`; too slow for a fit (a pass per command event)."""
    v, a = np.zeros(goals.shape[1]), np.zeros(goals.shape[1])
    v_out, a_out = np.empty_like(goals), np.empty_like(goals)
    gaps = np.diff(event_t, append=event_t[-1])
    for k in range(len(event_t)):
        v_out[k], a_out[k] = v, a
        v, a, _ = advance(v, a, goals[k], accel, jerk, gaps[k])
    return v_out, a_out
