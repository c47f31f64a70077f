"""The rolling ball of the MuJoCo table as a point model, for fast fitting of the effect parameters.

Between wall contacts a ball that rolls without slipping obeys, per unit mass (derivation in
docs/calibration.md; each line is checked against MuJoCo in tests/foos_calibration/test_calibration_effects.py):

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
SLIDING_FRICTION = 0.30  # the nominal ball-field Coulomb friction (foos_core/params/regulation_table.yaml)
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
    a = _Coefficients(theta)(_complex(p), _complex(v))
    return np.stack([a.real, a.imag], axis=1)


def _complex(xy: np.ndarray) -> np.ndarray:
    return xy[:, 0] + 1j * xy[:, 1]


def _real(z: np.ndarray) -> np.ndarray:
    return np.stack([z.real, z.imag], axis=-1)


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
        # Below 5 mm/s the rolling resistance fades out, so a ball comes to rest instead of reversing.
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
        self.pull = _complex(-mu * G * slip / np.maximum(size, 1e-12)[:, None])

    def kick(self, elapsed, h) -> tuple[np.ndarray, np.ndarray]:
        """(dp, dv) per ball, complex, for steps of length h starting `elapsed` seconds after the start."""
        s = np.clip(self.end - elapsed, 0.0, h)
        return self.pull * (s * (h - s / 2)), self.pull * s


def slide_duration(slip: np.ndarray, mu: float = SLIDING_FRICTION) -> np.ndarray:
    """Seconds (n,) each slip (n, 2) lasts before the ball rolls."""
    return np.sqrt(np.einsum("ij,ij->i", slip, slip)) / (SLIP_DECAY * mu * G)


def _rk4_step(acc: _Coefficients, p: np.ndarray, v: np.ndarray, h) -> tuple[np.ndarray, np.ndarray]:
    """One RK4 step of length h (a scalar, or one per ball) for complex positions and velocities."""
    h2 = 0.5 * h
    a1 = acc(p, v)
    v2 = v + h2 * a1
    a2 = acc(p + h2 * v, v2)
    v3 = v + h2 * a2
    a3 = acc(p + h2 * v2, v3)
    v4 = v + h * a3
    a4 = acc(p + h * v3, v4)
    return p + h / 6.0 * (v + 2 * (v2 + v3) + v4), v + h / 6.0 * (a1 + 2 * (a2 + a3) + a4)


def _slide_of(slip: np.ndarray | None, mu: float) -> _Slide | None:
    return _Slide(slip, mu) if slip is not None and np.any(slip != 0.0) else None


def integrate(p0: np.ndarray, v0: np.ndarray, theta: np.ndarray, nsteps: int, dt: float,
              slip: np.ndarray | None = None, mu: float = SLIDING_FRICTION) -> np.ndarray:
    """Positions (n, nsteps + 1, 2) on the grid k * dt from initial states (n, 2), RK4.

    `slip` (n, 2): the contact point's velocity at the start (zero for a ball that rolls).
    """
    out = np.empty((p0.shape[0], nsteps + 1), dtype=complex)
    acc = _Coefficients(theta)
    slide = _slide_of(slip, mu)
    p, v = _complex(p0), _complex(v0)
    out[:, 0] = p
    last_slide_step = int(np.ceil(np.max(slide.end) / dt)) if slide is not None else -1
    for k in range(nsteps):
        p, v = _rk4_step(acc, p, v, dt)
        if k < last_slide_step:
            dp, dv = slide.kick(k * dt, dt)
            p, v = p + dp, v + dv
        out[:, k + 1] = p
    return _real(out)


def integrate_state(p0: np.ndarray, v0: np.ndarray, theta: np.ndarray, duration: np.ndarray, dt: float,
                    slip: np.ndarray | None = None, mu: float = SLIDING_FRICTION):
    """Position and velocity (n, 2) of each ball after its own duration (n,), same RK4 (last step shortened)."""
    acc = _Coefficients(theta)
    slide = _slide_of(slip, mu)
    p, v = _complex(p0), _complex(v0)
    remaining = np.asarray(duration, dtype=float).copy()
    elapsed = np.zeros_like(remaining)
    while np.any(remaining > 1e-12):
        h = np.minimum(remaining, dt)
        p, v = _rk4_step(acc, p, v, h)
        if slide is not None:
            dp, dv = slide.kick(elapsed, h)
            p, v = p + dp, v + dv
        remaining = remaining - h
        elapsed = elapsed + h
    return _real(p), _real(v)
