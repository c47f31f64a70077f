"""The rolling ball of the MuJoCo table as a point model, for fast fitting of the effect parameters.

Between wall contacts a ball that rolls without slipping obeys, per unit mass (derivation in
docs/calibration.md; each line is checked against MuJoCo in tests/calibration/test_effects.py):

    a = 5/7 g s  -  d v/|v|  -  k v  -  c |v| v  -  5/7 g grad h(x, y)

with s the surface slope (table_tilt), d the rolling deceleration (rolling_resistance), k the viscous
rate, c the drag coefficient, and h the height of a cosine-bowl dent (surface_dent). Forces at the
centre of a rolling ball act on 7/5 of its mass, which is why slopes enter with 5/7 and the
contract's decelerations enter as they are. Integration is RK4, batched over segments (and over the
perturbed copies a finite-difference Jacobian needs), so one numpy pass integrates all of them.

After a wall bounce the ball slides: the bounce turned its velocity but not its spin. The contact
point then slips at u, and Coulomb friction pulls the centre at mu g against u while u itself
shrinks at 7/2 mu g (friction also turns the spin: 1 + m r^2 / I = 7/2 for a solid sphere). The
direction of u holds, so the slide is a constant pull -mu g u/|u| for |u| / (7/2 mu g) seconds, and
the ball rolls from then on. The effects act on a sliding ball a little differently (a slope pulls
at g s, not 5/7 g s), but a slide lasts 0.1-0.3 s, under 0.01 mm of difference; they are left as
for rolling.
"""
from __future__ import annotations

import numpy as np

G = 9.81
ROLL = 5.0 / 7.0
SLIDING_FRICTION = 0.30  # the nominal ball-field Coulomb friction (foos_sim/params/regulation_table.yaml)
SLIP_DECAY = 3.5  # slip shrinks 7/2 times as fast as friction slows the centre

# The full parameter vector; a candidate model frees some entries and holds the rest at nominal.
PARAM_NAMES = ("slope_x", "slope_y", "deceleration", "rate", "coefficient", "dent_x", "dent_y", "dent_radius", "dent_depth")
EFFECT_PARAMS = {
    "table_tilt": (0, 1),
    "rolling_resistance": (2,),
    "viscous_damping": (3,),
    "air_drag": (4,),
    "surface_dent": (5, 6, 7, 8),
}


def nominal_theta(rolling_deceleration: float = 0.15) -> np.ndarray:
    return np.array([0.0, 0.0, rolling_deceleration, 0.0, 0.0, 0.0, 0.0, 0.1, 0.0])


def acceleration(p: np.ndarray, v: np.ndarray, theta: np.ndarray) -> np.ndarray:
    """Acceleration (n, 2) of rolling balls at positions p (n, 2), velocities v (n, 2); theta (n, 9)."""
    speed = np.sqrt(np.einsum("ij,ij->i", v, v))[:, None]
    # Below 5 mm/s the rolling resistance fades out, so a ball comes to rest instead of reversing.
    a = ROLL * G * theta[:, 0:2] - theta[:, 2:3] * v / np.maximum(speed, 0.005)
    a -= (theta[:, 3:4] + theta[:, 4:5] * speed) * v
    depth = theta[:, 8]
    if np.any(depth != 0.0):
        delta = p - theta[:, 5:7]
        dist = np.sqrt(np.einsum("ij,ij->i", delta, delta))
        radius = theta[:, 7]
        inside = dist < radius
        slope = np.where(inside, 0.5 * depth * np.pi / radius * np.sin(np.pi * np.minimum(dist, radius) / radius), 0.0)
        a -= (ROLL * G * slope / np.maximum(dist, 1e-9))[:, None] * delta
    return a


class _Coefficients:
    """Theta's columns, pre-multiplied once per integration; positions and velocities are complex
    numbers x + iy, so each step costs half the numpy calls (the arrays are small, the calls dominate)."""

    def __init__(self, theta: np.ndarray):
        self.gravity = ROLL * G * (theta[:, 0] + 1j * theta[:, 1])
        self.d, self.k, self.c = theta[:, 2], theta[:, 3], theta[:, 4]
        self.dent = bool(np.any(theta[:, 8] != 0.0))
        self.centre, self.radius = theta[:, 5] + 1j * theta[:, 6], theta[:, 7]
        self.pull = ROLL * G * 0.5 * theta[:, 8] * np.pi / theta[:, 7]
        self.wave = np.pi / theta[:, 7]

    def __call__(self, p, v):
        speed = np.abs(v)
        a = self.gravity - (self.d / np.maximum(speed, 0.005) + self.k + self.c * speed) * v
        if self.dent:
            delta = p - self.centre
            dist = np.abs(delta)
            # sin(pi) is 1e-16, so balls outside the dent feel nothing without a mask.
            a -= self.pull * np.sin(self.wave * np.minimum(dist, self.radius)) / np.maximum(dist, 1e-9) * delta
        return a


class _Slide:
    """The friction pull of sliding balls, applied exactly beside each RK4 step (operator splitting).

    For a constant pull a during the first s seconds of a step of length h: dv = a s and
    dp = a s (h - s/2). Splitting ignores how the pull changes the other forces within one step
    (a velocity-dependent drag of 0.3 /s at most: well under a micrometre).
    """

    def __init__(self, slip: np.ndarray, mu: float):
        self.end = slide_duration(slip, mu)  # s after the start when the ball rolls
        size = self.end * (SLIP_DECAY * mu * G)  # |slip|; a zero slip gives a zero pull
        self.pull = -mu * G * slip / np.maximum(size, 1e-12)[:, None]

    def sliding_time(self, elapsed, h) -> np.ndarray:
        """Seconds of a step of length h, starting `elapsed` seconds after the start, that each ball slides."""
        return np.clip(self.end - elapsed, 0.0, h)

    def kick(self, elapsed: np.ndarray, h: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(dp, dv) per ball for steps of length h starting `elapsed` seconds after the start."""
        s = self.sliding_time(elapsed, h)
        return self.pull * (s * (h - s / 2))[:, None], self.pull * s[:, None]


def slide_duration(slip: np.ndarray, mu: float = SLIDING_FRICTION) -> np.ndarray:
    """Seconds (n,) each slip (n, 2) lasts before the ball rolls."""
    return np.sqrt(np.einsum("ij,ij->i", slip, slip)) / (SLIP_DECAY * mu * G)


def integrate(p0: np.ndarray, v0: np.ndarray, theta: np.ndarray, nsteps: int, dt: float,
              slip: np.ndarray | None = None, mu: float = SLIDING_FRICTION) -> np.ndarray:
    """Positions (n, nsteps + 1, 2) on the grid k * dt from initial states (n, 2), RK4.

    `slip` (n, 2): the contact point's velocity at the start (zero for a ball that rolls).
    """
    n = p0.shape[0]
    out = np.empty((n, nsteps + 1), dtype=complex)
    acc = _Coefficients(theta)
    slide = _Slide(slip, mu) if slip is not None and np.any(slip != 0.0) else None
    p, v = p0[:, 0] + 1j * p0[:, 1], v0[:, 0] + 1j * v0[:, 1]
    out[:, 0] = p
    h2, h6 = 0.5 * dt, dt / 6.0
    last_slide_step = int(np.ceil(np.max(slide.end) / dt)) if slide is not None else -1
    if slide is not None:
        pull = slide.pull[:, 0] + 1j * slide.pull[:, 1]
    for k in range(nsteps):
        a1 = acc(p, v)
        v2 = v + h2 * a1
        a2 = acc(p + h2 * v, v2)
        v3 = v + h2 * a2
        a3 = acc(p + h2 * v2, v3)
        v4 = v + dt * a3
        a4 = acc(p + dt * v3, v4)
        p = p + h6 * (v + 2 * (v2 + v3) + v4)
        v = v + h6 * (a1 + 2 * (a2 + a3) + a4)
        if k < last_slide_step:
            s = slide.sliding_time(k * dt, dt)
            p = p + pull * (s * (dt - s / 2))
            v = v + pull * s
        out[:, k + 1] = p
    return out.view(float).reshape(n, nsteps + 1, 2)


def integrate_state(p0: np.ndarray, v0: np.ndarray, theta: np.ndarray, duration: np.ndarray, dt: float,
                    slip: np.ndarray | None = None, mu: float = SLIDING_FRICTION):
    """Position and velocity of each ball after its own duration (n,), same RK4 (last step shortened)."""
    p, v = p0.copy(), v0.copy()
    slide = _Slide(slip, mu) if slip is not None and np.any(slip != 0.0) else None
    remaining = np.asarray(duration, dtype=float).copy()
    elapsed = np.zeros_like(remaining)
    while np.any(remaining > 1e-12):
        h = np.minimum(remaining, dt)[:, None]
        a1 = acceleration(p, v, theta)
        v2 = v + 0.5 * h * a1
        a2 = acceleration(p + 0.5 * h * v, v2, theta)
        v3 = v + 0.5 * h * a2
        a3 = acceleration(p + 0.5 * h * v2, v3, theta)
        v4 = v + h * a3
        a4 = acceleration(p + h * v3, v4, theta)
        p = p + h / 6.0 * (v + 2 * v2 + 2 * v3 + v4)
        v = v + h / 6.0 * (a1 + 2 * a2 + 2 * a3 + a4)
        if slide is not None:
            dp, dv = slide.kick(elapsed, h[:, 0])
            p, v = p + dp, v + dv
        remaining = remaining - h[:, 0]
        elapsed = elapsed + h[:, 0]
    return p, v
