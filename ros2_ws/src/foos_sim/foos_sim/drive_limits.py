"""The rod drives' own dynamics beyond the ideal velocity servo: dead time, top speed, acceleration limit.

The contract's drive effects (`rod_latency`, `rod_speed_limit`, `rod_acceleration_limit`, each for all
drives or for one team, rod or axis) turn the commands a team sent into the velocity target the servo
sees, in this order:

    received command --(dead time `delay`)--> clipped to the speed limit --(rate limit)--> servo target

- dead time: a drive acts on the last command it received at least `delay` seconds earlier;
- speed limit: the target never exceeds `slide` m/s or `rotate` rad/s (below the nominal command limits);
- acceleration limit: the target changes by at most `slide` m/s^2 (`rotate` rad/s^2) times the time step.

The MuJoCo servo (foos_sim.drives) then follows that target as before. DriveShaper is what
TableSimulation applies; predict_positions is the same model, integrated cheaply, for calibration: from
a drive's measured position and velocity and the commands, where it is some horizons later.

Every array over drives is in foos_core.names.JOINT_NAMES order (home then away, command order in each).
A parameter file with no drive effect gives no DriveLimits at all, so the nominal table is untouched.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Iterable, Optional, Sequence

import numpy as np

from foos_core.names import AXES, COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS

from . import scurve

DRIVE_EFFECT_NAMES = ("rod_latency", "rod_speed_limit", "rod_acceleration_limit")
MAX_DELAY = 1.0  # s: a dead time longer than this is a broken drive, not a parameter
_SELECTORS = {"team": TEAMS, "rod": RODS, "axis": AXES}
_TIME_EPS = 1e-9  # s: a command received exactly `delay` ago already acts


class DriveEffectError(ValueError):
    """A drive effect that cannot be applied (bad parameter, unknown team/rod/axis, given twice)."""


@dataclass(frozen=True)
class DriveLimits:
    """Per drive (JOINT_NAMES order): dead time (s), speed limit and acceleration limit (inf: none)."""

    delay: np.ndarray
    speed: np.ndarray
    acceleration: np.ndarray

    @property
    def max_delay(self) -> float:
        return float(self.delay.max())

    def team(self, team: str) -> "DriveLimits":
        """The 8 drives of one team, command order."""
        part = slice(TEAMS.index(team) * COMMAND_SIZE, (TEAMS.index(team) + 1) * COMMAND_SIZE)
        return DriveLimits(self.delay[part], self.speed[part], self.acceleration[part])


def _drive_mask(params: dict, name: str, allow_axis: bool) -> np.ndarray:
    """Which of the 16 drives an effect's optional team/rod(/axis) selects."""
    mask = np.ones(len(JOINT_NAMES), dtype=bool)
    for key, allowed in _SELECTORS.items():
        if key not in params:
            continue
        if key == "axis" and not allow_axis:
            raise DriveEffectError(f"effect `{name}` takes `slide` and/or `rotate` values, not `axis`")
        value = params[key]
        if value not in allowed:
            raise DriveEffectError(f"effect `{name}`: `{key}` must be one of {', '.join(allowed)}, not {value!r}")
        part = {"team": 0, "rod": 1, "axis": 2}[key]
        mask &= np.array([joint.split("_")[part] == value for joint in JOINT_NAMES])
    return mask


def _positive(name: str, key: str, value) -> float:
    try:
        number = float(value)
    except (TypeError, ValueError):
        raise DriveEffectError(f"effect `{name}`: `{key}` must be a number, not {value!r}") from None
    if not (math.isfinite(number) and number > 0):
        raise DriveEffectError(f"effect `{name}`: `{key}` must be a positive finite number")
    return number


def specificity(params: dict) -> int:
    """How narrowly an effect selects drives: a narrower one overrides a wider one on its drives."""
    return sum(key in params for key in _SELECTORS)


def drive_limits_from_effects(effects: Optional[Iterable[dict]]) -> Optional[DriveLimits]:
    """The drive limits a parameter file's effects describe, or None when it has no drive effect.

    An effect without team/rod/axis applies to every drive; one with them overrides it on the drives it
    selects (team+rod over team, and so on). The same selection given twice is an error.
    """
    drive_effects = [e for e in (effects or []) if isinstance(e, dict) and e.get("name") in DRIVE_EFFECT_NAMES]
    if not drive_effects:
        return None
    n = len(JOINT_NAMES)
    values = {"delay": np.zeros(n), "speed": np.full(n, np.inf), "acceleration": np.full(n, np.inf)}
    slide = np.array([joint.endswith("_slide") for joint in JOINT_NAMES])
    seen = set()
    for effect in sorted(drive_effects, key=lambda e: specificity(e.get("params") or {})):
        name, params = effect["name"], dict(effect.get("params") or {})
        key = (name, tuple(sorted((k, str(params[k])) for k in _SELECTORS if k in params)))
        if key in seen:
            raise DriveEffectError(f"effect `{name}` is given twice for the same drives")
        seen.add(key)
        mask = _drive_mask(params, name, allow_axis=name == "rod_latency")
        if name == "rod_latency":
            if "delay" not in params:
                raise DriveEffectError("effect `rod_latency` needs parameter `delay`")
            delay = float(params["delay"]) if isinstance(params["delay"], (int, float)) else math.nan
            if not (math.isfinite(delay) and 0.0 <= delay <= MAX_DELAY):
                raise DriveEffectError(f"effect `rod_latency`: `delay` must be a number of seconds in [0, {MAX_DELAY:g}]")
            values["delay"][mask] = delay
            continue
        target = values["speed"] if name == "rod_speed_limit" else values["acceleration"]
        given = [axis for axis in AXES if axis in params]
        if not given:
            raise DriveEffectError(f"effect `{name}` needs `slide` and/or `rotate`")
        for axis in given:
            axis_mask = mask & (slide if axis == "slide" else ~slide)
            target[axis_mask] = _positive(name, axis, params[axis])
    return DriveLimits(values["delay"], values["speed"], values["acceleration"])


class CommandHistory:
    """The teams' received commands and, per drive, the one it acts on after its dead time.

    receive() takes a team's (already validated and clipped) command at the simulation time it arrives;
    delayed_commands(time) gives the 16 commands the drives act on then; next_due(time) when one of them
    next changes.
    """

    def __init__(self, delay: np.ndarray):
        self.delay = np.asarray(delay, dtype=float)
        self.max_delay = float(self.delay.max())
        self._team_delay = [self.delay[t * COMMAND_SIZE:(t + 1) * COMMAND_SIZE] for t in range(len(TEAMS))]
        self._columns = np.arange(COMMAND_SIZE)
        self.reset()

    def reset(self) -> None:
        # The teams' command histories: times (k,) and values (k, 8); the first entry is the zero command at reset.
        self._times = [np.array([-np.inf]) for _ in TEAMS]
        self._values = [np.zeros((1, COMMAND_SIZE)) for _ in TEAMS]

    def receive(self, time: float, team: int, command: np.ndarray) -> None:
        times, values = self._times[team], self._values[team]
        if time <= times[-1]:  # a second command in the same instant replaces the first
            values[-1] = command
        else:
            # Keep only what can still act: the last command older than every delay, and what came after.
            keep = max(0, int(np.searchsorted(times, time - self.max_delay - _TIME_EPS, side="right")) - 1)
            self._times[team] = np.append(times[keep:], time)
            self._values[team] = np.vstack([values[keep:], command])

    def delayed_commands(self, time: float) -> np.ndarray:
        """The 16 commands each drive acts on at `time`: the last one it received `delay` earlier."""
        out = np.empty(len(JOINT_NAMES))
        for team in range(len(TEAMS)):
            times = self._times[team]
            index = np.searchsorted(times, time - self._team_delay[team] + _TIME_EPS, side="right") - 1
            out[team * COMMAND_SIZE:(team + 1) * COMMAND_SIZE] = self._values[team][index, self._columns]
        return out

    def next_due(self, time: float) -> float:
        """The first time after `time` at which a received command starts acting on a drive (inf: none)."""
        due = np.inf
        for team in range(len(TEAMS)):
            arrivals = self._times[team][:, None] + self._team_delay[team][None, :]
            later = arrivals[arrivals > time + _TIME_EPS]
            if later.size:
                due = min(due, float(later.min()))
        return due


class DriveShaper:
    """The servo drives' dead time, speed and acceleration limits between set_command and the servo target.

    receive() takes a team's (already validated and clipped) command at the simulation time it arrives;
    target(time, dt) returns the 16 servo targets for a physics step of dt starting at `time`. While no
    command is pending and no target is ramping, `idle` is True and the targets do not change.
    """

    def __init__(self, limits: DriveLimits, command_limits: np.ndarray):
        self.limits = limits
        self.speed = np.minimum(limits.speed, command_limits)  # what the target may reach
        self._accel = limits.acceleration
        self._limited = np.isfinite(self._accel)
        self._ramps = bool(self._limited.any())
        self.history = CommandHistory(limits.delay)
        self.reset()

    def reset(self) -> None:
        self.history.reset()
        self.value = np.zeros(len(JOINT_NAMES))
        self._pending_until = -np.inf  # the last time a received command still has to take effect
        self.idle = True
        self.updated_at = 0.0  # when target() last ran
        self.next_update = -np.inf  # when the target may next change (schedule())
        self._ramping = False

    def receive(self, time: float, team: int, command: np.ndarray) -> None:
        self.history.receive(time, team, command)
        self._pending_until = max(self._pending_until, time + self.limits.max_delay)
        self.idle = False
        self.next_update = min(self.next_update, time + float(self.limits.delay.min()))

    def delayed_commands(self, time: float) -> np.ndarray:
        return self.history.delayed_commands(time)

    def target(self, time: float, dt: float) -> np.ndarray:
        """The servo targets for a step of `dt` from `time` (also kept in `value`)."""
        goal = np.clip(self.delayed_commands(time), -self.speed, self.speed)
        if self._ramps:
            step = np.full(len(self._accel), np.inf)
            np.multiply(self._accel, max(dt, 0.0), out=step, where=self._limited)  # inf * 0 would be NaN
            np.add(self.value, np.clip(goal - self.value, -step, step), out=self.value)
        else:
            self.value[:] = goal
        self.updated_at = time
        self._ramping = not np.array_equal(self.value, goal)
        # Idle once every command has acted and every target has reached its goal.
        self.idle = time >= self._pending_until and not self._ramping
        return self.value

    def schedule(self, time: float, ramp_update: float) -> None:
        """After target(time): when the target next changes, a received command falling due or, while a target
        ramps, `ramp_update` later (for a physics that does not call target() every step)."""
        due = self.history.next_due(time)
        self.next_update = min(due, time + ramp_update) if self._ramping else due


@dataclass(frozen=True)
class Servo:
    """The nominal velocity servo of some drives: reflected inertia (kg or kg m^2), gain kv, force limit."""

    inertia: np.ndarray
    gain: np.ndarray
    force_limit: np.ndarray


def predict_positions(
    t0: np.ndarray,
    position: np.ndarray,
    velocity: np.ndarray,
    command_t: np.ndarray,
    commands: np.ndarray,
    limits: DriveLimits,
    servo: Servo,
    command_limits: np.ndarray,
    horizons: Sequence[float] = (0.1, 0.25),
    travel: Optional[np.ndarray] = None,
    dt: float = 0.002,
    profile: Optional[tuple[np.ndarray, np.ndarray]] = None,
    acceleration: Optional[np.ndarray] = None,
) -> np.ndarray:
    """Where D drives of one team are `horizons` after each of n starts: (n, H, D).

    t0 (n,), position and velocity (n, D) measured at t0; command_t (m,) arrival times and commands (m, D)
    of those drives; limits, servo, command_limits and travel (D,) for them (travel: the slide stops +/-,
    inf for rotations). The shaped target (dead time, speed limit, rate limit) is integrated at dt and
    followed by the servo as the fast physics steps it: implicit in the gain, clipped at the force limit.
    The rate limiter starts from the measured velocity (a servo follows its target within milliseconds).

    On the jerk-limited drives `profile` holds their generators' (acceleration limit, jerk limit) (D,) and
    `acceleration` (n, D) the setpoints' acceleration at t0: each drive then follows its S-curve
    (foos_sim.scurve) towards the shaped command, at the lower of its own and the effect's acceleration limit,
    exactly within each step (a command that falls due within a step splits it there), and the rod moves with it
    (foos_sim.drive_profiles).
    """
    t0 = np.asarray(t0, dtype=float)
    p = np.array(position, dtype=float)
    v = np.array(velocity, dtype=float)
    y = v.copy()
    speed = np.minimum(limits.speed, command_limits)
    accel_step = limits.acceleration * dt
    implicit = dt * servo.gain / (servo.inertia + dt * servo.gain)
    force_step = dt * servo.force_limit / servo.inertia
    # Where the force limit takes over (foos_sim.drives): MuJoCo clips a slide's force once kv |error| passes
    # it; a rotation (kv dt > I) is lifted while its implicit step stays within the limit.
    overshoots = servo.gain * dt > servo.inertia
    clipped_above = np.where(overshoots, servo.force_limit * (servo.inertia + dt * servo.gain) / (servo.gain * servo.inertia),
                             servo.force_limit / servo.gain)
    stop = np.full(p.shape[1], np.inf) if travel is None else np.asarray(travel, dtype=float)
    steps = [int(round(h / dt)) for h in horizons]
    out = np.full((len(t0), len(steps), p.shape[1]), np.nan)
    columns = np.arange(p.shape[1])
    if profile is not None:
        profile_accel = np.minimum(limits.acceleration, profile[0])
        a = np.zeros_like(v) if acceleration is None else np.array(acceleration, dtype=float)
    def acting(time):
        """The command index and clipped goal each drive acts on at `time` (n,): the last received `delay` before."""
        seen = time[:, None] - limits.delay[None, :] + _TIME_EPS
        index = np.searchsorted(command_t, seen.ravel(), side="right").reshape(seen.shape) - 1
        goal = np.where(index >= 0, commands[np.maximum(index, 0), columns[None, :]], 0.0)
        return index, np.clip(goal, -speed, speed)

    for k in range(max(steps) + 1):
        if k in steps:
            out[:, steps.index(k)] = p
        if k == max(steps):
            break
        index, goal = acting(t0 + k * dt)
        if profile is not None:
            # A generator re-plans the moment a command falls due, not at this step's start: a velocity change of 300
            # rad/s applied 1 ms late is 0.3 rad off. Where one falls due within the step, the step is split there.
            later, next_goal = acting(t0 + (k + 1) * dt - 2 * _TIME_EPS)
            due = np.where(later != index, command_t[np.maximum(later, 0)] + limits.delay[None, :] - (t0 + k * dt)[:, None], dt)
            due = np.clip(due, 0.0, dt)
            v, a, moved = scurve.advance(v, a, goal, profile_accel, profile[1], due)
            v, a, rest = scurve.advance(v, a, next_goal, profile_accel, profile[1], dt - due)
            p = p + moved + rest
        else:
            y = y + np.clip(goal - y, -accel_step, accel_step)
            error = y - v
            v = v + np.where(np.abs(error) > clipped_above, np.sign(error) * force_step, implicit * error)
            p = p + v * dt
        at_stop = np.abs(p) > stop
        if at_stop.any():
            p = np.clip(p, -stop, stop)
            v = np.where(at_stop, 0.0, v)
    return out
