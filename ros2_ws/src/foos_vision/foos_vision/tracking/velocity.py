"""Ball velocity two ways: the paper's central differences, and a constant-velocity Kalman filter."""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import numpy as np


def central_differences(t: np.ndarray, position: np.ndarray, max_gap: float = 0.1) -> np.ndarray:
    """v_k = (p_{k+1} - p_{k-1}) / (t_{k+1} - t_{k-1}); one-sided at the ends and next to gaps > max_gap; NaN alone."""
    t = np.asarray(t, float)
    p = np.asarray(position, float)
    v = np.full_like(p, math.nan)
    n = len(t)
    for k in range(n):
        prev_ok = k > 0 and t[k] - t[k - 1] <= max_gap
        next_ok = k < n - 1 and t[k + 1] - t[k] <= max_gap
        lo, hi = (k - 1 if prev_ok else k), (k + 1 if next_ok else k)
        if hi > lo:
            v[k] = (p[hi] - p[lo]) / (t[hi] - t[lo])
    return v


@dataclass
class KalmanState:
    t: float
    x: np.ndarray  # [x, y, vx, vy]
    P: np.ndarray  # 4x4


class ConstantVelocityKalman:
    """Constant velocity in the table plane, white-noise acceleration, position measurements.

    accel_noise is the spectral density of the unmodelled acceleration (m^2/s^3): rolling and friction
    are small, so it is small; wall and figure hits are not, and the innovation gate below
    restarts the track from the measured position when a hit is too hard to follow.
    """

    def __init__(self, measurement_std: float = 0.0015, accel_noise: float = 0.5, max_gap: float = 0.25,
                 restart_sigma: float = 4.0):
        self.r = measurement_std**2
        self.q = accel_noise
        self.max_gap = max_gap
        self.restart_sigma = restart_sigma
        self.state: KalmanState | None = None

    def reset(self) -> None:
        self.state = None

    def _predicted(self, t: float) -> tuple[np.ndarray, np.ndarray]:
        s = self.state
        dt = t - s.t
        f = np.eye(4)
        f[0, 2] = f[1, 3] = dt
        q = self.q * np.array([[dt**3 / 3, 0, dt**2 / 2, 0], [0, dt**3 / 3, 0, dt**2 / 2],
                               [dt**2 / 2, 0, dt, 0], [0, dt**2 / 2, 0, dt]])
        return f @ s.x, f @ s.P @ f.T + q

    def predict(self, t: float) -> KalmanState | None:
        """The state expected at t (the filter itself is unchanged); None without a live track."""
        if self.state is None or t - self.state.t > self.max_gap:
            return None
        x, p = self._predicted(t)
        return KalmanState(t, x, p)

    def update(self, t: float, xy: np.ndarray, covariance: Optional[np.ndarray] = None) -> KalmanState:
        """covariance: this measurement's (2x2, m^2), where it is not the filter's round measurement_std: a motion-
        blurred ball's centre is surer across its streak than along it."""
        xy = np.asarray(xy, float)
        r = self.r * np.eye(2) if covariance is None else np.asarray(covariance, float)
        if self.state is not None and t <= self.state.t:
            return self.state  # an out-of-order frame cannot move the filter backwards
        if self.state is None or t - self.state.t > self.max_gap:
            return self._start(t, xy, r)
        x, p = self._predicted(t)
        innovation = xy - x[:2]
        s = p[:2, :2] + r
        if innovation @ np.linalg.solve(s, innovation) > self.restart_sigma**2:
            # A hit (wall, figure, hand): the old velocity is no guide; start over from this position.
            return self._start(t, xy, r)
        gain = p[:, :2] @ np.linalg.inv(s)
        x = x + gain @ innovation
        p = (np.eye(4) - gain[:, :2] @ np.eye(2, 4)) @ p
        self.state = KalmanState(t, x, 0.5 * (p + p.T))
        return self.state

    def _start(self, t: float, xy: np.ndarray, r: np.ndarray) -> KalmanState:
        # A new track: position known to the measurement, velocity to what a hand can throw (3 m/s).
        p = np.diag([0.0, 0.0, 9.0, 9.0])
        p[:2, :2] = r
        self.state = KalmanState(t, np.array([xy[0], xy[1], 0.0, 0.0]), p)
        return self.state
