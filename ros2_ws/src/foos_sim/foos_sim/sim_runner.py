"""What sim_node does, without ROS: schedule samples, detections and goals over simulated time.

The runner owns a TableSimulation and advances it from one event to the next:
  - a state sample (joints and ball, ground truth) every 1 / publish_rate,
  - a camera capture every 1 / detection_rate, published detection_latency later, with optional
    Gaussian noise and dropouts (a frame whose ball is off the field publishes nothing),
  - or, with camera_rate > 0, a camera frame every 1 / camera_rate instead: the table's pose (qpos) at
    that time, which sim_node films (foos_sim.camera.live) and a tracker turns into detections,
  - a goal, followed by a new serve when serving is on.
It also plays the rod drives' watchdog: a team whose commands stop for command_timeout is stopped.
Event times are simulated seconds; sim_node maps them to ROS time and publishes.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Sequence

import numpy as np

from .simulation import TableSimulation

SERVES = ("none", "center", "random")


@dataclass
class RunnerConfig:
    publish_rate: float = 100.0  # Hz, /joint_states and /ball/state
    detection_rate: float = 120.0  # Hz, /ball/detection (the camera's frame rate)
    detection_noise: float = 0.0  # m, standard deviation per axis (x, y)
    detection_latency: float = 0.0  # s, from capture to publication
    detection_dropout: float = 0.0  # probability that a frame yields no detection
    camera_rate: float = 0.0  # Hz of camera frames to film; > 0 replaces the detections (a tracker makes them)
    command_timeout: float = 0.5  # s without a command before a team's rods are stopped
    serve: str = "random"
    initial_ball: tuple[float, float, float, float] = (0.0, 0.0, 0.0, 0.0)  # x, y, vx, vy for serve "none"
    serve_speed: tuple[float, float] = (0.3, 3.0)  # m/s, range of a random serve
    rest_speed: float = 0.01  # m/s; below this for rest_time the ball is at rest and is served again
    rest_time: float = 0.5
    seed: int = 0

    def validate(self) -> None:
        for name in ("publish_rate", "detection_rate", "command_timeout", "rest_time"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value > 0):
                raise ValueError(f"{name} must be a positive number, got {value}")
        for name in ("detection_noise", "detection_latency", "camera_rate"):
            value = getattr(self, name)
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"{name} must be zero or positive, got {value}")
        if not 0.0 <= self.detection_dropout < 1.0:
            raise ValueError(f"detection_dropout must be in [0, 1), got {self.detection_dropout}")
        if self.serve not in SERVES:
            raise ValueError(f"serve must be one of {', '.join(SERVES)}, got '{self.serve}'")
        if not all(math.isfinite(v) for v in self.initial_ball):
            raise ValueError("the initial ball state must be finite")


@dataclass(frozen=True)
class StateSample:
    time: float
    joint_positions: np.ndarray
    joint_velocities: np.ndarray
    joint_efforts: np.ndarray
    ball_position: np.ndarray
    ball_velocity: np.ndarray
    ball_angular_velocity: np.ndarray


@dataclass(frozen=True)
class Detection:
    capture_time: float  # the stamp: when the frame was taken
    publish_time: float
    position: np.ndarray


@dataclass(frozen=True)
class CameraFrame:
    capture_time: float  # the stamp: the simulated time of the state the frame shows
    qpos: np.ndarray  # the simulation's qpos then (its own layout), to film


@dataclass(frozen=True)
class Goal:
    time: float
    team: str  # the team that scored
    score: dict


@dataclass
class _Timers:
    next_sample: float = 0.0
    next_capture: float = 0.0  # a detection's capture, or a camera frame with camera_rate > 0
    pending: list = field(default_factory=list)  # detections waiting out their latency, by publish time


class SimRunner:
    def __init__(self, sim: TableSimulation, config: RunnerConfig):
        config.validate()
        self.sim = sim
        self.config = config
        self.rng = np.random.default_rng(config.seed)
        self.score = {"home": 0, "away": 0}
        self.reset()  # sets the timers, the watchdog's last commands and the rest detector

    # --- commands ------------------------------------------------------------------------------
    def command(self, team: str, values: Sequence[float], at: float | None = None) -> np.ndarray:
        """Apply a team's command (CommandError on bad input); returns what the drives were given. `at`: the
        simulated time it arrives, from now to the next event (TableSimulation.set_command); default now."""
        if at is not None:
            at = min(max(at, self.sim.time), self.next_event_time())
        clipped = self.sim.set_command(team, values, at=at)
        self._last_command[team] = self.sim.time
        return clipped

    def _watchdog(self) -> list[str]:
        stopped = []
        for team, last in self._last_command.items():
            if last > -math.inf and self.sim.time - last > self.config.command_timeout:
                self.sim.stop_team(team)
                self._last_command[team] = -math.inf
                stopped.append(team)
        return stopped

    # --- serving -------------------------------------------------------------------------------
    def _serve(self) -> None:
        c = self.config
        if c.serve == "none":
            x, y, vx, vy = c.initial_ball
            self.sim.place_ball((x, y), (vx, vy))
        elif c.serve == "center":
            self.sim.place_ball((0.0, 0.0), (0.0, 0.0))
        else:
            # A hand launch: anywhere on the field clear of walls and figures, any direction, a roll's speed.
            margin = 0.05
            for _ in range(100):
                x = self.rng.uniform(-self.sim.half_width + margin, self.sim.half_width - margin)
                y = self.rng.uniform(-self.sim.half_length + margin, self.sim.half_length - margin)
                speed = self.rng.uniform(*c.serve_speed)
                heading = self.rng.uniform(-math.pi, math.pi)
                self.sim.place_ball((x, y), (speed * math.cos(heading), speed * math.sin(heading)))
                if self.sim.ball_is_clear():
                    break
        self._rest_since = None
        self._goal_reported = False

    def reset(self) -> None:
        """Rods centred and stopped, ball served again; the score is kept."""
        self.sim.reset()
        self._serve()
        t = self.sim.time
        self._clock = t  # the last event's scheduled time: what advance() has asked of the simulation in all
        self._timers = _Timers(next_sample=t, next_capture=t)
        self._last_command = {"home": -math.inf, "away": -math.inf}

    # --- time ----------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return self.sim.time

    def next_event_time(self) -> float:
        timers = self._timers
        candidates = [timers.next_sample, timers.next_capture]
        if timers.pending:
            candidates.append(timers.pending[0].publish_time)
        return min(candidates)

    def advance(self) -> list:
        """Step to the next event and return what happened then: StateSample, Detection (or CameraFrame), Goal items.

        The simulation is asked for the time from one scheduled event to the next, so it follows the
        schedule within half a physics step (2 ms steps at the fast rate: a 120 Hz camera's frames are
        taken at the step nearest each 1/120 s, and stamped with that step's time)."""
        # A detection published with no latency falls due at its capture, which may be a little before
        # the schedule (a step's time); it is due now.
        target = max(self.next_event_time(), self._clock)
        goal_team = self.sim.advance(target - self._clock)
        self._clock = target
        now = self.sim.time
        # Events up to the scheduled time are due; a few nanoseconds spare what adding periods rounds.
        due = target + 1e-9
        events: list = []
        self._watchdog()
        timers = self._timers
        if timers.next_capture <= due:
            if self.config.camera_rate > 0:
                events.append(CameraFrame(now, self.sim.data.qpos.copy()))
                timers.next_capture += 1.0 / self.config.camera_rate
            else:
                self._capture(now)
                timers.next_capture += 1.0 / self.config.detection_rate
        while timers.pending and timers.pending[0].publish_time <= due:
            events.append(timers.pending.pop(0))
        if timers.next_sample <= due:
            events.append(self.sample())
            timers.next_sample += 1.0 / self.config.publish_rate
        if goal_team is not None and not self._goal_reported:
            self.score[goal_team] += 1
            events.append(Goal(now, goal_team, dict(self.score)))
            if self.config.serve != "none":
                self._serve()  # a new ball clears the simulation's goal latch
            else:
                self._goal_reported = True  # the ball stays in the pocket until a reset
        elif self.config.serve == "random" and self._ball_at_rest(now):
            self._serve()
        return events

    def _ball_at_rest(self, now: float) -> bool:
        if math.hypot(*self.sim.ball_velocity().tolist()) > self.config.rest_speed:
            self._rest_since = None
            return False
        if self._rest_since is None:
            self._rest_since = now
        return now - self._rest_since >= self.config.rest_time

    def _capture(self, now: float) -> None:
        c = self.config
        if c.detection_dropout > 0 and self.rng.random() < c.detection_dropout:
            return
        if not self.sim.ball_on_field():
            return  # the camera sees no ball in a goal pocket or in the air outside the field
        position = self.sim.ball_position()
        if c.detection_noise > 0:
            position[:2] += self.rng.normal(0.0, c.detection_noise, 2)
        self._timers.pending.append(Detection(now, now + c.detection_latency, position))

    def sample(self) -> StateSample:
        sim = self.sim
        return StateSample(
            time=sim.time,
            joint_positions=sim.joint_positions(),
            joint_velocities=sim.joint_velocities(),
            joint_efforts=sim.joint_efforts(),
            ball_position=sim.ball_position(),
            ball_velocity=sim.ball_velocity(),
            ball_angular_velocity=sim.ball_angular_velocity(),
        )
