"""Where the jerk-limited drives' rods are some horizons after a start: the S-curves integrated from command to command.

Between two instants at which a command starts acting on a drive (its arrival plus the drive's dead time) the drive's
generator follows one S-curve (foos_sim.scurve), whose velocity and distance are exact in closed form, and the rod
moves with the setpoint (foos_sim.drive_profiles). So the prediction steps from event to event, each lane (start,
drive) on its own events, not on a fixed step: every command acts at its own instant, however close it follows the
one before.

Why not foos_sim.drive_limits.predict_positions' fixed 2 ms steps: it splits a step at the first command that
falls due within it and starts the rest of the step on the command acting at the step's end, so a command that is
followed by another within the same step never acts. Commands sent every 2 ms arrive 1-3 ms apart under a transport
jitter of up to 1 ms; on a 6 s `fast_commands` game on the 20 kHz reference, with the commands at the times the drives
acted on them, the rotations' median error 0.25 s ahead was 12.9x the encoder noise with predict_positions and 1.2x with
this one (and rods.prediction_errors scoring at the encoder samples; docs/measurements/
calibration-2026-11-27-drive-prediction.md).

The servo drives (servo_positions) keep predict_positions: its servo is the fast physics' implicit 2 ms step.
"""
from __future__ import annotations

import numpy as np

from foos_sim import scurve
from foos_sim.drive_limits import DriveLimits, Servo, predict_positions

_TIME_EPS = 1e-9  # s: a command falling due at the start itself already acts (the start's state includes it)


def profile_positions(t0: np.ndarray, position: np.ndarray, velocity: np.ndarray, acceleration: np.ndarray,
                      due_t: np.ndarray, goals: np.ndarray, accel: np.ndarray, jerk: np.ndarray,
                      ends: np.ndarray, travel: np.ndarray) -> np.ndarray:
    """(n, H, D): the positions of D drives at `ends` (n, H: times at or after each start, ascending per start).

    t0 (n,); position, velocity and acceleration (n, D): the rods' positions and their setpoints' state at t0;
    due_t (m, D): when each command starts acting on each drive (ascending per drive), goals (m, D): what it asks
    (already clipped to the speed limit); accel, jerk (D,): the generators' limits; travel (D,): the slide stops
    (+/-, inf for rotations). A rod driven into a stop stays there while its generator, which does not see the
    stop, goes on (foos_sim.drive_profiles)."""
    t0 = np.asarray(t0, dtype=float)
    n, d = np.asarray(position).shape
    m = len(due_t)
    p = np.array(position, dtype=float)
    v = np.array(velocity, dtype=float)
    a = np.array(acceleration, dtype=float)
    accel = np.broadcast_to(np.asarray(accel, dtype=float), (n, d))
    jerk = np.broadcast_to(np.asarray(jerk, dtype=float), (n, d))
    stop = np.broadcast_to(np.asarray(travel, dtype=float), (n, d))
    columns = np.arange(d)[None, :]
    # Per lane: the next command to fall due after t0, and the goal acting at t0.
    k = np.stack([np.searchsorted(due_t[:, j], t0 + _TIME_EPS, side="right") for j in range(d)], axis=1)
    goal = np.where(k > 0, goals[np.maximum(k - 1, 0), columns], 0.0)
    padded = np.vstack([due_t, np.full((1, d), np.inf)])  # k == m: no command left
    time = np.repeat(t0[:, None], d, axis=1)
    ends = np.asarray(ends, dtype=float)
    out = np.full((n, ends.shape[1], d), np.nan)
    for h in range(ends.shape[1]):
        end = ends[:, h, None]
        while True:
            upcoming = padded[k, columns]
            reach = np.minimum(upcoming, end)
            elapsed = reach - time
            if not (elapsed > 0).any() and not (upcoming <= end).any():
                break
            v, a, moved = scurve.advance(v, a, goal, accel, jerk, np.maximum(elapsed, 0.0))
            p = np.clip(p + moved, -stop, stop)
            time = np.maximum(time, reach)
            due = upcoming <= end
            if due.any():
                goal = np.where(due, goals[np.minimum(k, m - 1), columns], goal)
                k = k + due
        out[:, h] = p
    return out


def servo_positions(t0: np.ndarray, position: np.ndarray, velocity: np.ndarray, command_t: np.ndarray, commands: np.ndarray,
                    limits: DriveLimits, servo: Servo, command_limits: np.ndarray, travel: np.ndarray, dt: float,
                    ends: np.ndarray) -> np.ndarray:
    """(n, H, D): the velocity servos' rods at `ends` (n, H), by foos_sim.drive_limits.predict_positions on its steps
    of dt, interpolated between the two steps around each end."""
    offsets = (np.asarray(ends, dtype=float) - np.asarray(t0, dtype=float)[:, None]) / dt
    below = np.floor(offsets + 1e-9).astype(int)
    steps = np.unique(np.concatenate([below.ravel(), below.ravel() + 1]))
    predicted = predict_positions(t0, position, velocity, command_t, commands, limits, servo, command_limits,
                                  tuple(steps * dt), travel, dt)
    at = np.searchsorted(steps, below)
    rows = np.arange(len(offsets))[:, None]
    share = np.clip(offsets - below, 0.0, 1.0)[:, :, None]
    return (1.0 - share) * predicted[rows, at] + share * predicted[rows, at + 1]
