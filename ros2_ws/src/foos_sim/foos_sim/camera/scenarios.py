"""Rollouts for the synthetic camera: what the table does while it is filmed.

- `play`: random hand-launch rolls (0.3-3 m/s) with every rod moving and kicking, so figures
  occlude the ball and hit it; now and then the ball is taken out of sight (picked up by a hand).
- `rolls`: rods turned horizontal and held there, random rolls only: clean rolling data for
  calibrating rolling resistance and table tilt.
- `StateReplay`: ball and rod states recorded by sim_node or a tracker (bag_inputs reads them from a bag),
  replayed and interpolated; `detections_at`: the measured ball (/ball/detection) at the frame times.
"""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

from foos_core.names import BALL_JOINT, COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS
from foos_sim.simulation import TableSimulation

SCENARIOS = ("play", "rolls")


class SimRollout:
    """Steps a TableSimulation forward to any requested time, with a scripted table around it."""

    def __init__(self, sim: TableSimulation, scenario: str = "play", seed: int = 0,
                 hide_every: float = 0.0, hide_for: float = 0.4, speed_range=(0.3, 3.0), no_ball: bool = False):
        if scenario not in SCENARIOS:
            raise ValueError(f"unknown scenario `{scenario}` (one of {SCENARIOS})")
        self.sim, self.scenario = sim, scenario
        self.rng = np.random.default_rng(seed)
        self.speed_range = speed_range if scenario == "play" else (0.3, min(1.5, speed_range[1]))
        self.hide_every, self.hide_for = hide_every, hide_for
        self.no_ball = no_ball
        self.steps = 0
        self.slow_since: Optional[float] = None
        self.hidden_until = -1.0
        self.next_hide = hide_every if hide_every > 0 else math.inf
        n_rods = len(JOINT_NAMES) // 2
        self.phase = self.rng.uniform(0, 2 * math.pi, n_rods)
        self.freq = self.rng.uniform(0.3, 1.2, n_rods)
        self.kick_target = np.zeros(n_rods)
        self.next_kick = self.rng.uniform(0.2, 1.0, n_rods)
        self._serve()

    def _joint_start(self) -> np.ndarray:
        q = np.zeros(len(JOINT_NAMES))
        if self.scenario == "rolls":
            q[1::2] = math.pi / 2  # every rotate joint: figures horizontal, clear of the ball
        return q

    def _serve(self) -> None:
        sim, rng = self.sim, self.rng
        joints = self.sim.joint_positions() if self.steps else self._joint_start()
        x = rng.uniform(-0.8, 0.8) * (sim.half_width - 0.05)
        y = rng.uniform(-0.85, 0.85) * (sim.half_length - 0.05)
        speed = rng.uniform(*self.speed_range)
        # Aim at a random point on the field, so rolls cross the table rather than hit the nearest wall.
        target = np.array([rng.uniform(-0.25, 0.25), rng.uniform(-0.5, 0.5)])
        direction = target - (x, y)
        direction /= max(np.linalg.norm(direction), 1e-6)
        t = sim.time
        sim.reset(ball_position=(x, y), ball_velocity=tuple(speed * direction), rolling=True, joint_positions=joints)
        sim.data.time = t
        self.slow_since = None

    def _drive_rods(self, t: float) -> None:
        q = self.sim.joint_positions()
        for team_index, team in enumerate(TEAMS):
            command = np.zeros(COMMAND_SIZE)
            for rod in range(len(RODS)):
                i = team_index * len(RODS) + rod
                angle = q[2 * i + 1]
                if self.scenario == "rolls":
                    command[2 * rod + 1] = -20.0 * (angle - math.pi / 2)
                    continue
                command[2 * rod] = 0.35 * math.sin(2 * math.pi * self.freq[i] * t + self.phase[i])
                if t >= self.next_kick[i]:
                    # A kick: swing back, then through; or lift the figures clear for a while.
                    self.kick_target[i] = self.rng.choice([0.0, 0.0, -0.6, 0.8, math.pi / 2])
                    self.next_kick[i] = t + self.rng.uniform(0.3, 1.5)
                command[2 * rod + 1] = -15.0 * (angle - self.kick_target[i])
            self.sim.set_command(team, command)

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray, bool]:
        sim = self.sim
        target_steps = int(round(t / sim.timestep))
        chunk = max(1, int(round(0.002 / sim.timestep)))  # re-plan the rods every 2 ms
        while self.steps < target_steps:
            n = min(chunk, target_steps - self.steps)
            self._drive_rods(sim.time)
            goal = sim.step(n)
            self.steps += n
            speed = float(np.linalg.norm(sim.ball_velocity()[:2]))
            if speed < 0.03:
                self.slow_since = self.slow_since if self.slow_since is not None else sim.time
            else:
                self.slow_since = None
            resting = self.slow_since is not None and sim.time - self.slow_since > 0.3
            if goal is not None or resting or not sim.ball_on_field() or sim.ball_position()[2] < -0.05:
                self._serve()
            if sim.time >= self.next_hide:
                self.hidden_until = sim.time + self.hide_for
                self.next_hide = sim.time + self.hide_every * self.rng.uniform(0.7, 1.3)
        hidden = self.no_ball or t < self.hidden_until
        return sim.data.qpos.copy(), sim.ball_velocity(), hidden


MAX_DETECTION_GAP = 0.1  # s: detections further apart than this are not joined (the camera lost the ball between)


def detections_at(t: np.ndarray, position: np.ndarray, times: np.ndarray, max_gap: float = MAX_DETECTION_GAP) -> np.ndarray:
    """The measured ball at each of times, (n, 3): interpolated between the two detections around it when they are
    at most max_gap apart, NaN elsewhere (before the first, after the last, across a longer gap). t: (N,) sorted."""
    times = np.atleast_1d(np.asarray(times, float))
    out = np.full((len(times), 3), np.nan)
    after = np.searchsorted(t, times, side="right")  # t[after - 1] <= time < t[after]
    inside = (after > 0) & (after < len(t))
    a, b = after[inside] - 1, after[inside]
    joined = t[b] - t[a] <= max_gap
    weight = ((times[inside] - t[a]) / (t[b] - t[a]))[:, None]
    between = position[a] * (1 - weight) + position[b] * weight
    out[np.flatnonzero(inside)[joined]] = between[joined]
    out[times == t[-1]] = position[-1]
    return out


class StateReplay:
    """Recorded ball and rod states (bag_inputs.RecordedStates), interpolated to the requested times; time 0 is the
    recording's start. Without ball states the ball is out of sight (only the measured one is drawn, over the
    image); without joint states the rods stay as the model has them: centred, figures hanging."""

    def __init__(self, sim: TableSimulation, recorded):
        self.sim = sim
        self.t0 = recorded.start
        self.duration = recorded.end - self.t0
        self.ball_t = None if recorded.t is None else recorded.t - self.t0
        self.ball_p, self.ball_v = recorded.ball_position, recorded.ball_velocity
        self.joint_t = None if recorded.joint_t is None else recorded.joint_t - self.t0
        self.joint_p = recorded.joint_position
        ball = sim.model.joint(BALL_JOINT)
        self.qpos_ball = ball.qposadr[0]
        self.qpos_joints = np.array([sim.model.joint(n).qposadr[0] for n in JOINT_NAMES])

    def state_at(self, t: float) -> tuple[np.ndarray, np.ndarray, bool]:
        qpos = self.sim.data.qpos.copy()
        if self.joint_t is not None:
            qpos[self.qpos_joints] = [np.interp(t, self.joint_t, self.joint_p[:, i]) for i in range(len(JOINT_NAMES))]
        if self.ball_t is None:
            return qpos, np.zeros(3), True
        p = np.array([np.interp(t, self.ball_t, self.ball_p[:, i]) for i in range(3)])
        v = np.array([np.interp(t, self.ball_t, self.ball_v[:, i]) for i in range(3)])
        qpos[self.qpos_ball:self.qpos_ball + 3] = p
        qpos[self.qpos_ball + 3:self.qpos_ball + 7] = (1, 0, 0, 0)
        return qpos, v, False
