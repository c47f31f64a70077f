"""Where the rods are some horizons after a start: the nominal drives integrated exactly from command to command.

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

The velocity servos on the reference physics (or a real table: continuous_servo_positions) are integrated exactly in
continuous time from event to event too: predict_positions steps them as the fast physics' implicit 2 ms step does, so
a command acts up to 2 ms late and a slide (I / kv 3-5 ms) follows its command as an implicit Euler step, not as its
servo. On the same game on the servo table's reference (servo_reference_table.yaml), rotations 5.3x -> 1.2x and slides
9.3x -> 1.0x (medians over drives). On the fast physics the servos are what predict_positions steps
(stepped_servo_positions): there a rotation ends each step at its command, with no lag (foos_sim.drives), and the
servo law's 0.25 ms lag was 3.8x the noise where predict_positions was 1.3x (a 20 s default-style game).
"""
from __future__ import annotations

import numpy as np

from foos_sim import scurve
from foos_sim.drive_limits import DriveLimits, Servo, predict_positions

_TIME_EPS = 1e-9  # s: a command falling due at the start itself already acts (the start's state includes it)


def nearest_samples(t: np.ndarray, times: np.ndarray) -> np.ndarray:
    """The index of the sample of t (ascending) nearest each of `times`."""
    after = np.clip(np.searchsorted(t, times), 1, len(t) - 1)
    return np.where(times - t[after - 1] < t[after] - times, after - 1, after)


def _commands_at(t0: np.ndarray, due_t: np.ndarray, goals: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Per start and drive lane: (lane columns (1, D), k (n, D): the next command to fall due after t0, the goal acting
    at t0 (n, D), due_t padded with a row of inf: k == m, no command left)."""
    d = due_t.shape[1]
    columns = np.arange(d)[None, :]
    k = np.stack([np.searchsorted(due_t[:, j], t0 + _TIME_EPS, side="right") for j in range(d)], axis=1)
    goal = np.where(k > 0, goals[np.maximum(k - 1, 0), columns], 0.0)
    return columns, k, goal, np.vstack([due_t, np.full((1, d), np.inf)])


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
    columns, k, goal, padded = _commands_at(t0, due_t, goals)
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


def continuous_servo_positions(t0: np.ndarray, position: np.ndarray, velocity: np.ndarray, target: np.ndarray,
                               due_t: np.ndarray, goals: np.ndarray, rate: np.ndarray, servo: Servo,
                               ends: np.ndarray, travel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """(n, H, D): velocity servos' rods at `ends` (n, H), the servo integrated exactly in continuous time; and (n, D)
    their velocities at the last end.

    The servo's force is kv (y - v), clipped to its force limit F: unclipped, the velocity error e = y - v decays with
    the time constant tau = I / kv (e' = r - e / tau while the target y ramps at r); clipped, the rod accelerates at
    F / I. The target y ramps at `rate` (D,: the acceleration limit, inf: none) towards each command's goal from
    when it falls due. position, velocity (n, D) and target (n, D): the rods, their velocities and the targets at t0;
    due_t, goals (m, D) as in profile_positions. A rod at a stop stops there."""
    t0 = np.asarray(t0, dtype=float)
    n, d = np.asarray(position).shape
    m = len(due_t)
    p, v, y = (np.array(x, dtype=float) for x in (position, velocity, target))
    tau = np.broadcast_to(servo.inertia / servo.gain, (n, d))
    reach = np.broadcast_to(servo.force_limit / servo.inertia, (n, d))  # F / I
    clip_error = np.broadcast_to(servo.force_limit / servo.gain, (n, d))  # F / kv
    rate = np.broadcast_to(np.asarray(rate, dtype=float), (n, d))
    stop = np.broadcast_to(np.asarray(travel, dtype=float), (n, d))
    columns, k, goal, padded = _commands_at(t0, due_t, goals)
    y = np.where(np.isinf(rate), goal, y)
    time = np.repeat(t0[:, None], d, axis=1)
    ends = np.asarray(ends, dtype=float)
    out = np.full((n, ends.shape[1], d), np.nan)
    with np.errstate(divide="ignore", invalid="ignore"):
        for h in range(ends.shape[1]):
            end = ends[:, h, None]
            while True:
                upcoming = padded[k, columns]
                gap = goal - y
                r = np.where(gap == 0.0, 0.0, np.sign(gap) * rate)
                r = np.where(np.isinf(r), 0.0, r)
                ramp_end = np.where(r != 0.0, gap / r, np.inf)
                e = y - v
                clipped = np.abs(e) > clip_error * (1.0 + 1e-9) + 1e-12  # (at the edge: free, so the loop moves on)
                s = np.sign(e)
                exit_after = np.where(clipped, (np.abs(e) - clip_error) / np.maximum(reach - s * r, 1e-12), np.inf)
                step = np.minimum(np.minimum(upcoming, end) - time, np.minimum(ramp_end, exit_after))
                step = np.maximum(step, 0.0)
                if not (step > 0).any() and not (upcoming <= end).any():
                    break
                # Clipped: constant acceleration. Free: the error relaxes towards r tau.
                decay = np.exp(-step / tau)
                e_free = r * tau + (e - r * tau) * decay
                moved_free = y * step + 0.5 * r * step * step - (r * tau * step + (e - r * tau) * tau * (1.0 - decay))
                v_clipped = v + s * reach * step
                moved_clipped = v * step + 0.5 * s * reach * step * step
                y = np.where(np.isfinite(ramp_end) & (step >= ramp_end), goal, y + r * step)
                v = np.where(clipped, v_clipped, y - e_free)
                p = p + np.where(clipped, moved_clipped, moved_free)
                at_stop = np.abs(p) > stop
                p = np.clip(p, -stop, stop)
                v = np.where(at_stop, 0.0, v)
                time = time + step
                due = (upcoming <= end) & (time >= upcoming - _TIME_EPS)
                if due.any():
                    goal = np.where(due, goals[np.minimum(k, m - 1), columns], goal)
                    y = np.where(due & np.isinf(rate), goal, y)
                    k = k + due
            out[:, h] = p
    return out, v


def stepped_servo_positions(t0: np.ndarray, position: np.ndarray, velocity: np.ndarray, command_t: np.ndarray, commands: np.ndarray,
                            limits: DriveLimits, servo: Servo, command_limits: np.ndarray, travel: np.ndarray, dt: float,
                            ends: np.ndarray) -> np.ndarray:
    """(n, H, D): the velocity servos' rods at `ends` (n, H) as the fast physics steps them (foos_sim.drive_limits.
    predict_positions on steps of dt), interpolated between the two steps around each end."""
    offsets = (np.asarray(ends, dtype=float) - np.asarray(t0, dtype=float)[:, None]) / dt
    below = np.floor(offsets + 1e-9).astype(int)
    steps = np.unique(np.concatenate([below.ravel(), below.ravel() + 1]))
    predicted = predict_positions(t0, position, velocity, command_t, commands, limits, servo, command_limits,
                                  tuple(steps * dt), travel, dt)
    at = np.searchsorted(steps, below)
    rows = np.arange(len(offsets))[:, None]
    share = np.clip(offsets - below, 0.0, 1.0)[:, :, None]
    return (1.0 - share) * predicted[rows, at] + share * predicted[rows, at + 1]
