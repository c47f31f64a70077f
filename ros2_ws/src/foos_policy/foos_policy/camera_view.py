"""The ball as a real table's camera loop delivers it to a controller: late and noisy (ROS-free).

A controller on a real robot table never sees the ball's state now. It sees a camera frame up to one frame
old, found by a tracker, sent on, and its command takes a while to reach the drives. Both teams in the env
act on this view of the ball by default (EnvConfig.view / opponent_view "camera"); "instant" is the true
state at once, kept for comparison. The rods' own joints come from encoders, at once, as on a real table.

The figures, with their sources:
- CAMERA_LATENCY 40 ms: a 60 fps frame (up to 17 ms old), detection and the command's way (issue 26:
  KiRo's 50 Hz camera with a 20 ms cycle; 60-90 fps cameras with a detector). The project's own chain
  past the camera (image published -> detection arrived: tracker and two DDS hops) measured 20-36 ms
  median on the loaded 2-core machine (docs/measurements/sim-2026-11-27-camera-loop.md).
- POSITION_NOISE 1.5 mm per axis: the tracker's error on the vision bench (medians 0.8-1.6 mm;
  docs/vision.md), the figure issue 26 names.
- VELOCITY_NOISE 0.05 m/s per axis: the tracker's Kalman speed error, 0.02-0.11 m/s median
  (docs/measurements/vision-2026-11-21-error-budget.md); a 2-D Gaussian of 0.05 per axis has a median
  error of 0.06 m/s.
"""
from __future__ import annotations

import math
from collections import deque
from typing import Optional

import numpy as np

VIEWS = ("camera", "instant")
CAMERA_LATENCY = 0.040  # s
POSITION_NOISE = 0.0015  # m, standard deviation per axis (x, y)
VELOCITY_NOISE = 0.05  # m/s, standard deviation per axis
HISTORY = 64  # control steps kept: 1.28 s at 50 Hz, far more than any latency here


class CameraView:
    """The ball `latency` seconds ago (linear between the recorded states), with Gaussian noise; one
    measurement per control step, shared by both teams (one camera films the table)."""

    def __init__(self, latency: float = CAMERA_LATENCY, position_noise: float = POSITION_NOISE,
                 velocity_noise: float = VELOCITY_NOISE):
        for name, value in (("latency", latency), ("position noise", position_noise), ("velocity noise", velocity_noise)):
            if not (math.isfinite(value) and value >= 0):
                raise ValueError(f"the camera's {name} must be zero or positive, got {value}")
        self.latency = float(latency)
        self.position_noise = float(position_noise)
        self.velocity_noise = float(velocity_noise)
        self._states: deque = deque(maxlen=HISTORY)  # (time, position (3,), velocity (3,))
        self._seen: Optional[tuple[np.ndarray, np.ndarray]] = None

    def clear(self) -> None:
        """A new episode: nothing seen yet."""
        self._states.clear()
        self._seen = None

    def record(self, time: float, position, velocity, rng: np.random.Generator) -> None:
        """The true ball at `time` (after each control step, and at reset); draws this step's measurement."""
        self._states.append((float(time), np.array(position, float), np.array(velocity, float)))
        position, velocity = self._late(self._states[-1][0] - self.latency)
        position, velocity = position.copy(), velocity.copy()
        if self.position_noise > 0:
            position[:2] += rng.normal(0.0, self.position_noise, 2)
        if self.velocity_noise > 0:
            velocity[:2] += rng.normal(0.0, self.velocity_noise, 2)
        self._seen = (position, velocity)

    def ball(self) -> tuple[np.ndarray, np.ndarray]:
        """What the camera loop delivers now: position and velocity (3-vectors, table frame)."""
        if self._seen is None:
            raise RuntimeError("the camera has seen nothing yet: record() the state first")
        return self._seen

    def _late(self, when: float) -> tuple[np.ndarray, np.ndarray]:
        """The recorded state at `when`, linear between records; the oldest one before them (a new episode's
        first frames show its start)."""
        states = self._states
        if when <= states[0][0]:
            return states[0][1], states[0][2]
        for newer in range(len(states) - 1, 0, -1):  # from the newest: the latency is a few records back
            (t0, p0, v0), (t1, p1, v1) = states[newer - 1], states[newer]
            if t0 <= when <= t1:
                share = 0.0 if t1 == t0 else (when - t0) / (t1 - t0)
                return p0 + share * (p1 - p0), v0 + share * (v1 - v0)
        return states[-1][1], states[-1][2]
