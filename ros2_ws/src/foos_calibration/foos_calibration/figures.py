"""The figures a physicist would draw of the residuals (matplotlib, Agg)."""
from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from foos_core.table_geometry import TableGeometry  # noqa: E402

from . import surrogate  # noqa: E402
from .tracks import Measured, _linear_velocity, normal_speed  # noqa: E402


def _save(fig, path: Path) -> None:
    """Every figure of the report the same way: tight, at 110 dpi, then closed (pyplot holds it until then)."""
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def local_kinematics(measured: Measured, window: float = 0.25, stride: int = 6):
    """Position, velocity and acceleration from quadratic fits over windows of the rolling segments."""
    P, V, A = [], [], []
    for seg in measured.segments:
        rolling = seg.t >= seg.rolls_from  # a slide's friction is not a residual of the rolling model
        t, xy = seg.t[rolling], seg.xy[rolling]
        k = 0
        while k < len(t):
            m = (t >= t[k]) & (t <= t[k] + window)
            if m.sum() >= 15 and t[m][-1] - t[m][0] >= 0.8 * window:
                tau = t[m] - t[m].mean()
                X = np.stack([np.ones_like(tau), tau, 0.5 * tau**2], axis=1)
                c, *_ = np.linalg.lstsq(X, xy[m], rcond=None)
                P.append(c[0])
                V.append(c[1])
                A.append(c[2])
            k += stride
    if not P:
        return np.zeros((0, 2)), np.zeros((0, 2)), np.zeros((0, 2))
    return np.array(P), np.array(V), np.array(A)


def _field_outline(ax, geometry: TableGeometry) -> None:
    hx, hy, gw = geometry.half_width, geometry.half_length, geometry.goal_half_width
    ax.plot([-hx, hx, hx, -hx, -hx], [-hy, -hy, hy, hy, -hy], color="k", lw=1)
    for s in (-1, 1):
        ax.plot([-gw, gw], [s * hy, s * hy], color="w", lw=3)
    ax.set_aspect("equal")
    ax.set_xlim(-hx - 0.03, hx + 0.03)
    ax.set_ylim(-hy - 0.03, hy + 0.03)
    ax.set_xlabel("x (m)")
    ax.set_ylabel("y (m)")


def residual_map(measured: Measured, geometry: TableGeometry, nominal_theta: np.ndarray, found: list[dict], path: Path) -> None:
    P, V, A = local_kinematics(measured)
    fig, ax = plt.subplots(figsize=(5.2, 8))
    if len(P):
        R = A - surrogate.acceleration(P, V, np.tile(nominal_theta, (len(P), 1)))
        cell = 0.085
        ix = np.floor((P[:, 0] + geometry.half_width) / cell).astype(int)
        iy = np.floor((P[:, 1] + geometry.half_length) / cell).astype(int)
        nx, ny = int(np.ceil(2 * geometry.half_width / cell)), int(np.ceil(2 * geometry.half_length / cell))
        ok = (ix >= 0) & (ix < nx) & (iy >= 0) & (iy < ny)
        sum_r = np.zeros((ny, nx, 2))
        count = np.zeros((ny, nx))
        np.add.at(sum_r, (iy[ok], ix[ok]), R[ok])
        np.add.at(count, (iy[ok], ix[ok]), 1)
        mean = np.where(count[..., None] >= 3, sum_r / np.maximum(count, 1)[..., None], np.nan)
        xs = -geometry.half_width + (np.arange(nx) + 0.5) * cell
        ys = -geometry.half_length + (np.arange(ny) + 0.5) * cell
        X, Y = np.meshgrid(xs, ys)
        mag = np.hypot(mean[..., 0], mean[..., 1])
        im = ax.pcolormesh(np.append(xs - cell / 2, xs[-1] + cell / 2), np.append(ys - cell / 2, ys[-1] + cell / 2),
                           mag, cmap="viridis", shading="flat")
        fig.colorbar(im, ax=ax, label="|residual acceleration| (m/s²)", shrink=0.7)
        ax.quiver(X, Y, mean[..., 0], mean[..., 1], color="w", angles="xy")
        overall = np.nanmean(R, axis=0)
        ax.set_title(f"Residual acceleration vs nominal\nmean ({overall[0]:+.3f}, {overall[1]:+.3f}) m/s²", fontsize=10)
    _field_outline(ax, geometry)
    for e in found:
        if e["name"] == "surface_dent":
            p = e["params"]
            ax.add_patch(plt.Circle((p["x"], p["y"]), p["radius"], fill=False, color="r", lw=2, ls="--"))
    _save(fig, path)


def deceleration_vs_speed(measured: Measured, nominal_rolling: float, theta: np.ndarray, path: Path) -> None:
    P, V, A = local_kinematics(measured)
    fig, ax = plt.subplots(figsize=(6, 4))
    if len(P):
        speed = np.hypot(V[:, 0], V[:, 1])
        decel = -np.einsum("ij,ij->i", A, V) / np.maximum(speed, 1e-6)
        ax.scatter(speed, decel, s=4, alpha=0.25, color="0.5", label="windows of 0.25 s")
        bins = np.linspace(0.05, max(0.5, speed.max()), 10)
        mid, mean, err = [], [], []
        for a, b in zip(bins[:-1], bins[1:]):
            m = (speed >= a) & (speed < b)
            if m.sum() >= 5:
                mid.append(0.5 * (a + b))
                mean.append(np.mean(decel[m]))
                err.append(np.std(decel[m]) / np.sqrt(m.sum()))
        ax.errorbar(mid, mean, yerr=err, fmt="o", color="k", label="binned mean")
        s = np.linspace(0, speed.max(), 100)
        ax.plot(s, np.full_like(s, nominal_rolling), "b--", label="nominal model")
        ax.plot(s, theta[2] + theta[3] * s + theta[4] * s**2, "r-", label="calibrated model")
        ax.set_ylim(min(-0.2, np.percentile(decel, 2)), max(0.6, np.percentile(decel, 98)))
    ax.set_xlabel("speed (m/s)")
    ax.set_ylabel("along-track deceleration (m/s²)")
    ax.set_title("Deceleration against speed: constant = rolling, linear = viscous, quadratic = drag", fontsize=9)
    ax.legend(fontsize=8)
    _save(fig, path)


def bounce_speeds(measured: Measured) -> list[tuple[str, float, float]]:
    """(wall, normal speed in, normal speed out) from 6-frame fits on each side of each contact."""
    out = []
    for b in measured.bounces:
        before, after = measured.flights[b.before], measured.flights[b.after]
        if len(before.t) < 6 or len(after.t) < 6:
            continue
        v_in = _linear_velocity(before.t[-6:], before.xy[-6:])
        v_out = _linear_velocity(after.t[:6], after.xy[:6])
        out.append((b.wall, normal_speed(b.wall, v_in), -normal_speed(b.wall, v_out)))
    return out


def wall_bounces(measured: Measured, nominal: float, fitted: float | None, path: Path) -> None:
    data = bounce_speeds(measured)
    fig, ax = plt.subplots(figsize=(5, 4.5))
    colors = {"side_neg_x": "C0", "side_pos_x": "C1", "end_home": "C2", "end_away": "C3"}
    for wall, c in colors.items():
        pts = np.array([(i, o) for w, i, o in data if w == wall])
        if len(pts):
            ax.scatter(pts[:, 0], pts[:, 1], s=14, color=c, label=wall)
    top = max([d[1] for d in data] + [1.0])
    s = np.linspace(0, top, 10)
    ax.plot(s, nominal * s, "b--", label=f"nominal e = {nominal:.2f}")
    if fitted is not None:
        ax.plot(s, fitted * s, "r-", label=f"calibrated e = {fitted:.2f}")
    ax.set_xlabel("normal speed in (m/s)")
    ax.set_ylabel("normal speed out, first 50 ms (m/s)")
    ax.set_title("Wall bounces (out speed just after contact,\nalready slowed by sliding)", fontsize=9)
    ax.legend(fontsize=7)
    _save(fig, path)


def tracks_overlay(measured: Measured, geometry: TableGeometry, predictions, path: Path, count: int = 6) -> None:
    fig, ax = plt.subplots(figsize=(5.2, 8))
    _field_outline(ax, geometry)
    starts = predictions.starts
    if starts:
        pick = np.linspace(0, len(starts) - 1, min(count, len(starts))).astype(int)
        for n, i in enumerate(pick):
            s = starts[i]
            t, xy = measured.tracks[s.track]
            m = (t >= s.t0 - 0.3) & (t <= s.t0 + 1.0)
            ax.plot(xy[m, 0], xy[m, 1], ".", ms=2, color="k", label="measured" if n == 0 else None)
            for label, style in (("nominal", "b--"), ("calibrated", "r-")):
                if label in predictions.tracks:
                    _, pos = predictions.tracks[label]
                    ax.plot(pos[i, :, 0], pos[i, :, 1], style, lw=1.2, label=f"{label} (1 s)" if n == 0 else None)
            ax.plot(*xy[m][0], "ko", ms=3)
        ax.legend(fontsize=8, loc="upper right")
    ax.set_title("Measured tracks and 1 s predictions from held-out starts", fontsize=9)
    _save(fig, path)
