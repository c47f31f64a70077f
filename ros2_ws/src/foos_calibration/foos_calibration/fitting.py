"""Fitting the rolling-ball effects: segments' initial states jointly with few global parameters.

Gauss-Newton (scipy `least_squares`, trust region) over all rolling segments at once. Each segment
has its own initial state (x, y, vx, vy), estimated jointly with the effect parameters rather than
from noisy finite differences; a segment that starts at a wall bounce also has its initial slip
(ux, uy), because the ball slides there until friction matches its spin to its velocity. The
Jacobian is formed in one batched RK4 pass: every segment is
integrated once as it is, once per state component nudged, and once per free global parameter
nudged, all in the same numpy arrays; the state columns are block-sparse.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Sequence

import numpy as np
from scipy import sparse
from scipy.optimize import least_squares

from foos_core.table_geometry import TableGeometry

from . import surrogate
from .tracks import Segment

DT = 1.0 / 120.0  # s, RK4 step of the surrogate (0.04 mm off a 1/960 s reference through a 5 cm dent at 3 m/s)
STATE_STEP = np.array([1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5])  # x, y, vx, vy, ux, uy
PARAM_STEP = np.array([1e-6, 1e-6, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-5, 1e-7])
# Relative change of the squared error (and of the unknowns) that ends a fit: 1e-6 of ~10^4 noise
# variances is 0.01, far below the 30 that name an effect. Tighter, the slides' slips keep Gauss-Newton
# creeping to the evaluation limit for nothing (4x the time).
FIT_TOLERANCE = 1e-6
SLIP_LIMIT = 4.0  # m/s, each slip component
MAX_DENT_DEPTH = 0.006  # m: the deepest dent (or highest bump) a table can have; dents worth naming are 1-4 mm


def parameter_bounds(geometry: TableGeometry) -> tuple[np.ndarray, np.ndarray]:
    """Lower and upper bounds of the 9 parameters (surrogate.PARAM_NAMES); a dent's centre lies on the field."""
    hx, hy = geometry.half_width, geometry.half_length
    lower = np.array([-0.05, -0.05, 0.0, 0.0, 0.0, -hx, -hy, 0.03, -MAX_DENT_DEPTH])
    upper = np.array([0.05, 0.05, 2.0, 3.0, 2.0, hx, hy, 0.30, MAX_DENT_DEPTH])
    return lower, upper


class SegmentBatch:
    """Rolling segments as padded arrays on the RK4 grid."""

    def __init__(self, segments: Sequence[Segment]):
        self.segments = list(segments)
        n = len(self.segments)
        L = max(len(s.t) for s in self.segments)
        self.n, self.L = n, L
        self.tau = np.zeros((n, L))
        self.meas = np.zeros((n, L, 2))
        self.mask = np.zeros((n, L), dtype=bool)
        for i, s in enumerate(self.segments):
            m = len(s.t)
            self.tau[i, :m] = s.t - s.t[0]
            self.meas[i, :m] = s.xy
            self.mask[i, :m] = True
        self.nsteps = int(np.ceil(self.tau.max() / DT)) + 1
        self.idx = np.minimum((self.tau / DT).astype(int), self.nsteps - 1)
        self.frac = (self.tau - self.idx * DT) / DT
        self.seg_of, self.sample_of = np.nonzero(self.mask)
        self.nres = 2 * len(self.seg_of)
        # Sliding segments carry two more unknowns, the slip's components, after the 4 n states.
        self.slides = np.array([s.slide for s in self.segments], dtype=bool)
        self.slip_column = np.full(n, -1)
        self.slip_column[self.slides] = 4 * n + 2 * np.arange(int(self.slides.sum()))
        self.nstate = 4 * n + 2 * int(self.slides.sum())

    def pack(self, states: np.ndarray) -> np.ndarray:
        """States (n, 6) -> the fit's state unknowns (x, y, vx, vy of each; then the slides' ux, uy)."""
        return np.concatenate([states[:, :4].ravel(), states[self.slides, 4:6].ravel()])

    def unpack(self, x: np.ndarray) -> np.ndarray:
        states = np.zeros((self.n, 6))
        states[:, :4] = x[: 4 * self.n].reshape(self.n, 4)
        states[self.slides, 4:6] = x[4 * self.n: self.nstate].reshape(-1, 2)
        return states

    def initial_states(self) -> np.ndarray:
        """(n, 6) states from a quadratic fit to each segment's first 0.3 s; slips from the bounce."""
        states = np.zeros((self.n, 6))
        for i, s in enumerate(self.segments):
            m = s.t - s.t[0] < 0.3
            tau = s.t[m] - s.t[0]
            A = np.stack([np.ones_like(tau), tau, tau**2], axis=1)
            coef, *_ = np.linalg.lstsq(A, s.xy[m], rcond=None)
            states[i, :4] = (*coef[0], *coef[1])
            if s.slide:
                states[i, 4:6] = s.slip_guess
        return states

    def predict(self, states: np.ndarray, theta: np.ndarray) -> np.ndarray:
        """Predicted positions (B, L, 2) for B = n * k rows (states (B, 6) and theta tiled per row)."""
        grid = surrogate.integrate(states[:, :2], states[:, 2:4], theta, self.nsteps, DT, slip=states[:, 4:6])
        rows = np.arange(grid.shape[0])[:, None]
        reps = grid.shape[0] // self.n
        idx = np.tile(self.idx, (reps, 1))
        frac = np.tile(self.frac, (reps, 1))[..., None]
        nxt = np.minimum(idx + 1, self.nsteps)
        return grid[rows, idx] * (1 - frac) + grid[rows, nxt] * frac

    def residual_of(self, prediction: np.ndarray) -> np.ndarray:
        return (prediction[: self.n][self.seg_of, self.sample_of] - self.meas[self.seg_of, self.sample_of]).ravel()


@dataclass
class Fit:
    free: tuple[int, ...]  # indices into surrogate.PARAM_NAMES
    theta: np.ndarray  # full 9-vector
    states: np.ndarray  # (n, 6): x, y, vx, vy, and the slip ux, uy (zero where the segment rolls from its start)
    rss: float  # m^2
    nres: int


def jacobian(batch: SegmentBatch, states: np.ndarray, theta: np.ndarray, free: Sequence[int]):
    """Residuals and their sparse Jacobian over [states (4 per segment, 2 more per slide), theta[free]], in one pass."""
    n, m = batch.n, len(free)
    seg, smp = batch.seg_of, batch.sample_of
    rows = np.arange(batch.nres).reshape(-1, 2)
    nudges = [np.eye(6)[j] * STATE_STEP[j] for j in range(6)]
    # A rolling segment's slip stays zero: nudging it would start a slide that is not there.
    blocks_s = [states] + [states + nudge * (batch.slides[:, None] if j >= 4 else 1.0) for j, nudge in enumerate(nudges)]
    blocks_s += [states] * m
    blocks_t = [np.tile(theta, (n, 1))] * 7
    for j in free:
        t = theta.copy()
        t[j] += PARAM_STEP[j]
        blocks_t.append(np.tile(t, (n, 1)))
    pred = batch.predict(np.concatenate(blocks_s), np.concatenate(blocks_t))
    base = pred[:n][seg, smp]
    data, ri, ci = [], [], []
    sliding = batch.slides[seg]
    for j in range(6):
        d = (pred[(1 + j) * n:(2 + j) * n][seg, smp] - base) / STATE_STEP[j]
        if j < 4:
            data.append(d.ravel())
            ri.append(rows.ravel())
            ci.append(np.repeat(4 * seg + j, 2))
        else:
            data.append(d[sliding].ravel())
            ri.append(rows[sliding].ravel())
            ci.append(np.repeat(batch.slip_column[seg[sliding]] + j - 4, 2))
    for k, j in enumerate(free):
        d = (pred[(7 + k) * n:(8 + k) * n][seg, smp] - base) / PARAM_STEP[j]
        data.append(d.ravel())
        ri.append(rows.ravel())
        ci.append(np.full(batch.nres, batch.nstate + k))
    J = sparse.csr_matrix((np.concatenate(data), (np.concatenate(ri), np.concatenate(ci))), shape=(batch.nres, batch.nstate + m))
    return (base - batch.meas[seg, smp]).ravel(), J


def fit(batch: SegmentBatch, free: Sequence[int], theta0: np.ndarray, states0: np.ndarray | None = None,
        max_nfev: int = 30, geometry: TableGeometry | None = None) -> Fit:
    """Least squares over the segments' states and the free parameters (the others held).

    A dent's centre is kept on the field of `geometry` (the regulation table's by default).
    """
    free = tuple(sorted(free))
    lower, upper = parameter_bounds(geometry if geometry is not None else TableGeometry.nominal())
    n, ns = batch.n, batch.nstate
    states0 = batch.initial_states() if states0 is None else states0
    theta0 = theta0.copy()
    # Slides come from bounces under 1.5 m/s, so a slip over SLIP_LIMIT is a misfit being soaked up.
    state_limit = np.concatenate([np.full(4 * n, np.inf), np.full(ns - 4 * n, SLIP_LIMIT)])
    lo = np.concatenate([-state_limit, lower[list(free)]])
    hi = np.concatenate([state_limit, upper[list(free)]])
    x0 = np.concatenate([np.clip(batch.pack(states0), -state_limit + 1e-6, state_limit - 1e-6),
                         np.clip(theta0[list(free)], lower[list(free)] + 1e-6, upper[list(free)] - 1e-6)])

    def unpack(x):
        theta = theta0.copy()
        theta[list(free)] = x[ns:]
        return batch.unpack(x), theta

    def fun(x):
        states, theta = unpack(x)
        return batch.residual_of(batch.predict(states, np.tile(theta, (n, 1))))

    def jac(x):
        return jacobian(batch, *unpack(x), free)[1]

    result = least_squares(fun, x0, jac=jac, bounds=(lo, hi), method="trf", tr_solver="lsmr",
                           x_scale="jac", max_nfev=max_nfev, xtol=FIT_TOLERANCE, ftol=FIT_TOLERANCE)
    states, theta = unpack(result.x)
    return Fit(free, theta, states, float(np.sum(result.fun**2)), batch.nres)


def predicted_drops(batch: SegmentBatch, current: Fit, candidates: dict[str, Sequence[int]]) -> dict[str, float]:
    """Squared-error drop (m^2) each candidate's parameters would buy, by one linearised step.

    A score test: residuals and Jacobian at the current fit once, then a small normal-equations
    solve per candidate. Used to rank candidates before the one full fit that counts.
    """
    sets = [current.free] + [tuple(set(params) | set(current.free)) for params in candidates.values()]
    base, *extended = linearised_rss(batch, current, current.theta, sets)
    return {name: base - rss for name, rss in zip(candidates, extended)}


def linearised_rss(batch: SegmentBatch, current: Fit, theta0: np.ndarray, free_sets: Sequence[Sequence[int]]) -> list[float]:
    """Squared error (m^2) of the model with each set of parameters refitted, by one Gauss-Newton step from `current`.

    For each set: the parameters `current` frees and the set does not go back to theta0, and the
    states and the set's parameters are refitted. One Jacobian at `current` serves every set. A screen:
    the effects' forces are linear in their parameters, so one step is close to the full refit.
    """
    columns = sorted(set(current.free).union(*map(set, free_sets)))
    r, J = jacobian(batch, current.states, current.theta, columns)
    JtJ = (J.T @ J).toarray()
    Jtr = J.T @ r
    rr = float(r @ r)
    ns = batch.nstate
    column = {j: ns + k for k, j in enumerate(columns)}
    out = []
    for free in free_sets:
        kept = list(range(ns)) + [column[j] for j in sorted(set(free))]
        # The residuals once the dropped parameters are back at theta0: r + J_d delta, in normal-equation terms.
        dropped = [j for j in current.free if j not in free]
        d = [column[j] for j in dropped]
        delta = theta0[dropped] - current.theta[dropped]
        b = Jtr[kept] + JtJ[np.ix_(kept, d)] @ delta
        rss = rr + 2 * delta @ Jtr[d] + delta @ JtJ[np.ix_(d, d)] @ delta
        A = JtJ[np.ix_(kept, kept)] + 1e-12 * np.eye(len(kept))
        out.append(float(rss - b @ np.linalg.solve(A, b)))
    return out


def fit_states(batch: SegmentBatch, theta: np.ndarray, states0: np.ndarray | None = None) -> Fit:
    """Only the segments' initial states, with every parameter held (held-out evaluation)."""
    return fit(batch, (), theta, states0, max_nfev=20)


DENT_REACH = 0.04  # m: how far a neighbourhood search may move a dent's centre (and 3 cm its radius)


def _centres_around(centre, reach: float, step: float = 0.01) -> np.ndarray:
    """A square grid of candidate dent centres (C, 2) within `reach` of `centre` in x and y."""
    offsets = np.arange(-reach, reach + step / 100, step)
    return np.stack([a.ravel() for a in np.meshgrid(centre[0] + offsets, centre[1] + offsets)], axis=1)


def _dent_gains(path, w, tau, h, residual, centres, radii):
    """Matched-filter gain and depth of each (centre, radius) candidate."""
    s0_all, s1_all, s2_all = w.sum(1), (w * tau).sum(1), (w * tau**2).sum(1)
    det_all = np.maximum(s0_all * s2_all - s1_all**2, 1e-12)
    best = (np.zeros(4), 0.0)
    lo_all, hi_all = path.min(axis=1), path.max(axis=1)  # (n, 2) bounding boxes of the segments
    for radius in radii:
        for start in range(0, len(centres), 48):
            c = centres[start:start + 48]  # (C, 2)
            # Only segments that pass within a radius of these centres can respond.
            near = np.all((hi_all > c.min(0) - radius) & (lo_all < c.max(0) + radius), axis=1)
            if not np.any(near):
                continue
            s0, s1, s2, det = s0_all[near], s1_all[near], s2_all[near], det_all[near]
            wr = w[near][None, :, :, None]
            res = residual[near]
            delta = path[near][None] - c[:, None, None, :]  # (C, n, K, 2)
            dist = np.sqrt(np.sum(delta**2, axis=-1))
            inside = dist < radius
            if not np.any(inside):
                continue
            slope = np.where(inside, 0.5 * np.pi / radius * np.sin(np.pi * np.minimum(dist, radius) / radius), 0.0)
            accel = -(surrogate.ROLL * surrogate.G * slope / np.maximum(dist, 1e-9))[..., None] * delta  # per m of depth
            resp = np.cumsum(np.cumsum(accel, axis=2) * h, axis=2) * h  # from a zero initial state
            # What a segment's own initial state absorbs: the best line in time, per segment and axis.
            b0 = (wr * resp).sum(2)
            b1 = (wr * resp * tau[None, None, :, None]).sum(2)
            a0 = (s2[None, :, None] * b0 - s1[None, :, None] * b1) / det[None, :, None]
            a1 = (s0[None, :, None] * b1 - s1[None, :, None] * b0) / det[None, :, None]
            resp = resp - a0[:, :, None, :] - a1[:, :, None, :] * tau[None, None, :, None]
            num = np.sum(resp * res[None], axis=(1, 2, 3))
            den = np.sum(wr * resp**2, axis=(1, 2, 3))
            # Depth limited to what a table can have: an unlimited linear depth lets a spot where a
            # few segments misfit for another reason (a slide after a bounce) outbid the real dent
            # with an absurd 2 cm bump.
            depth = np.clip(num / np.maximum(den, 1e-30), -MAX_DENT_DEPTH, MAX_DENT_DEPTH)
            gain = np.where(den > 0, 2 * depth * num - depth**2 * den, 0.0)
            k = int(np.argmax(gain))
            if gain[k] > best[1]:
                best = (np.array([c[k, 0], c[k, 1], radius, depth[k]]), float(gain[k]))
    return best


def dent_search(batch: SegmentBatch, base: Fit, geometry: TableGeometry | None = None,
                around: np.ndarray | None = None) -> tuple[np.ndarray, float]:
    """The dent (x, y, radius, depth) that best explains the residuals of `base`, by a matched filter.

    Linearised: a shallow dent adds to each segment the double integral of its pull along the
    fitted path, minus what the segment's own initial state can absorb (a line in time per axis).
    Each centre and radius on a grid gets its least-squares depth and the squared-residual drop it
    buys (m^2); a coarse 4 cm grid over the field of `geometry` (the regulation table's by default) is
    refined to 1 cm around the best. With `around` (x, y, radius) only its neighbourhood is searched
    (within 4 cm and 3 cm of radius).
    """
    n = batch.n
    grid = surrogate.integrate(base.states[:, :2], base.states[:, 2:4], np.tile(base.theta, (n, 1)), batch.nsteps, DT,
                               slip=base.states[:, 4:6])
    stride = 2
    path = grid[:, ::stride]  # (n, K, 2)
    h = DT * stride
    K = path.shape[1]
    residual = np.zeros((n, K, 2))
    w = np.zeros((n, K))
    near = np.minimum((batch.tau / h).round().astype(int), K - 1)
    r = batch.meas - batch.predict(base.states, np.tile(base.theta, (n, 1)))
    rows = np.nonzero(batch.mask)[0]
    np.add.at(residual, (rows, near[batch.mask]), r[batch.mask])
    np.add.at(w, (rows, near[batch.mask]), 1.0)
    tau = np.arange(K) * h
    if around is not None:
        radii = np.clip(around[2] + np.array([-0.03, -0.015, 0.0, 0.015, 0.03]), 0.04, 0.2)
        return _dent_gains(path, w, tau, h, residual, _centres_around(around, DENT_REACH), radii)
    geometry = geometry if geometry is not None else TableGeometry.nominal()
    hx, hy = geometry.half_width, geometry.half_length
    xs = np.arange(-hx + 0.04, hx - 0.04 + 1e-9, 0.04)
    ys = np.arange(-hy + 0.04, hy - 0.04 + 1e-9, 0.04)
    centres = np.stack([a.ravel() for a in np.meshgrid(xs, ys)], axis=1)
    coarse, _ = _dent_gains(path, w, tau, h, residual, centres, (0.05, 0.08, 0.12, 0.16))
    radii = np.clip(coarse[2] + np.array([-0.02, 0.0, 0.02]), 0.04, 0.2)
    centres = _centres_around(coarse, 0.03)
    return _dent_gains(path, w, tau, h, residual, centres, radii)
