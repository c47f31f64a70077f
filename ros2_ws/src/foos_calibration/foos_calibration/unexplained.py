"""Where the calibrated model still misses: what its residuals leave, by place, speed and kind of event.

A report must never say the data is explained while its own residuals are far above the noise. The
selection names an effect only on held-out evidence, so when the truth lies outside the vocabulary
(or two effects hide each other), it may name nothing, and "no effect found" is then no proof that the
model fits. This module looks at the residuals themselves: every frame of every rolling segment,
predicted by the calibrated model from its segment's fitted start, against the detection.

A place is *unexplained* when the root mean square of its residuals (per axis) is more than
FAR_ABOVE times the detection noise there, over at least MIN_FRAMES frames of MIN_SEGMENTS segments.
The residual of a model that is right is the noise (a little less: each segment's start is fitted),
plus the camera's slowly varying errors, which on the project's renders and generator leave 1.0-1.3x.
The places are the whole of the rolling data, cells of the field, bands of the ball's speed, and kinds
of event: the first moments after a wall bounce (the slide) and after a figure contact.

A segment's start is fitted, so a smooth misfit (an unmodelled tilt) hides in short segments: over
1.5 s a missed slope of 0.0055 left 1.9x the noise. What it cannot hide is the prediction 1 s ahead
from a start's short history, the report's own measure. So the held-out predictions are judged too,
against the error a right model would have from the noise alone (`prediction_floor`: the history's
detections redrawn with the measured noise, the start re-estimated and carried forward): 3.4-3.6 mm
at 1 s on the generator's recordings with nothing hidden, where a missed tilt of 0.0055 gave 20 mm.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

from foos_core.table_geometry import TableGeometry  # noqa: E402

from . import surrogate  # noqa: E402
from .evaluate import HORIZONS, Start, estimate_states  # noqa: E402
from .fitting import DT, Fit, SegmentBatch, fit_states  # noqa: E402
from .tracks import Flight, Segment  # noqa: E402

FAR_ABOVE = 3.0  # residual RMS over the detection noise that is far above it
MIN_FRAMES = 120  # frames a place needs (1 s at 120 fps) before its residual is judged
MIN_SEGMENTS = 3  # and segments: one odd roll is not a place
# Held-out starts a horizon needs before its predictions are judged: the median of fewer has no distribution-free
# 95 % bound (the least of 6 errors lies under their median with probability 1/64; of 4, 1/16). A game's figures
# leave few stretches long enough: the demo's game had 4 starts 0.5 s long, and their median (16.7 mm, with an
# interval of 1.7-37 mm) was flagged at 5.6x the noise.
MIN_PREDICTION_STARTS = 6
CELL = 0.2  # m, about the size of a field cell (the field is split into whole cells of about this)
SPEED_BANDS = (0.0, 0.3, 1.0, 2.0, np.inf)  # m/s
AFTER_EVENT = 0.3  # s: "just after" a wall bounce or a figure contact
FIGURE_FILE = "unexplained.png"
FLOOR_DRAWS = 8  # redraws of every start's history noise for the prediction floor


@dataclass
class Residuals:
    """Per frame of the rolling segments: where, how fast, and how far off the model is."""

    xy: np.ndarray  # (N, 2) measured position, m
    residual: np.ndarray  # (N, 2) model - measurement, m
    speed: np.ndarray  # (N,) the model's ball speed, m/s
    since_start: np.ndarray  # (N,) s since the segment began
    segment: np.ndarray  # (N,) segment index
    after_wall: np.ndarray  # (N,) the segment starts at a wall bounce
    after_figure: np.ndarray  # (N,) the segment starts at a figure contact


def residuals_of(segments: Sequence[Segment], fit: Fit, flights: Sequence[Flight] | None = None) -> Residuals:
    """Per-frame residuals; `flights` (the segments' flights, by index) tell which start at a figure contact."""
    batch = SegmentBatch(segments)
    prediction = batch.predict(fit.states, np.tile(fit.theta, (batch.n, 1)))
    seg, smp = batch.seg_of, batch.sample_of
    # The model's velocity along each segment, from its own (smooth) positions.
    tau = np.where(batch.mask, batch.tau, np.nan)
    velocity = np.zeros_like(prediction)
    for i in range(batch.n):
        m = int(batch.mask[i].sum())
        if m >= 2:
            velocity[i, :m] = np.gradient(prediction[i, :m], tau[i, :m], axis=0)
    starts_at_figure = np.array([flights is not None and flights[s.flight].after_figure and flights[s.flight].t[0] == s.t[0]
                                 for s in batch.segments], dtype=bool)
    starts_at_wall = np.array([s.slide for s in batch.segments], dtype=bool) & ~starts_at_figure
    return Residuals(
        xy=batch.meas[seg, smp],
        residual=prediction[seg, smp] - batch.meas[seg, smp],
        speed=np.linalg.norm(velocity[seg, smp], axis=1),
        since_start=batch.tau[seg, smp],
        segment=seg,
        after_wall=starts_at_wall[seg],
        after_figure=starts_at_figure[seg],
    )


def _rms(residual: np.ndarray) -> float:
    """Root mean square per axis (comparable with the per-axis detection noise)."""
    return float(np.sqrt(np.mean(residual**2))) if len(residual) else 0.0


def places(res: Residuals, geometry: TableGeometry) -> list[tuple[str, str, np.ndarray]]:
    """(kind, where, frame mask) of every place judged."""
    out = [("all", "all rolling data", np.ones(len(res.speed), dtype=bool))]
    nx = max(1, round(2 * geometry.half_width / CELL))
    ny = max(1, round(2 * geometry.half_length / CELL))
    xs = np.linspace(-geometry.half_width, geometry.half_width, nx + 1)
    ys = np.linspace(-geometry.half_length, geometry.half_length, ny + 1)
    ix = np.clip(np.searchsorted(xs, res.xy[:, 0]) - 1, 0, nx - 1)
    iy = np.clip(np.searchsorted(ys, res.xy[:, 1]) - 1, 0, ny - 1)
    for i in range(nx):
        for j in range(ny):
            where = f"the field at x {xs[i]:+.2f}..{xs[i + 1]:+.2f} m, y {ys[j]:+.2f}..{ys[j + 1]:+.2f} m"
            out.append(("region", where, (ix == i) & (iy == j)))
    for low, high in zip(SPEED_BANDS[:-1], SPEED_BANDS[1:]):
        where = f"ball speed {low:g}-{high:g} m/s" if np.isfinite(high) else f"ball speed over {low:g} m/s"
        out.append(("speed", where, (res.speed >= low) & (res.speed < high)))
    soon = res.since_start < AFTER_EVENT
    out.append(("event", f"the first {AFTER_EVENT:g} s after a wall bounce", res.after_wall & soon))
    out.append(("event", f"the first {AFTER_EVENT:g} s after a figure contact", res.after_figure & soon))
    return out


def find_unexplained(segments: Sequence[Segment], fit: Fit, noise: float, geometry: TableGeometry,
                     figure: Path | None = None, flights: Sequence[Flight] | None = None) -> list[dict]:
    """The places where the fitted model's residuals are far above the noise (contract: report.json `unexplained`).

    The whole of the data comes first when it is flagged; the other places follow, worst first. Draws
    the residual of every place, against the noise, to `figure` when given.
    """
    if not segments:
        return []
    res = residuals_of(segments, fit, flights)
    judged = []
    for kind, where, mask in places(res, geometry):
        frames, count = int(mask.sum()), len(np.unique(res.segment[mask]))
        rms = _rms(res.residual[mask])
        enough = frames >= MIN_FRAMES and count >= MIN_SEGMENTS
        judged.append((kind, where, mask, rms, frames, count, enough))
    found = []
    for kind, where, mask, rms, frames, count, enough in judged:
        if enough and rms > FAR_ABOVE * noise:
            entry = {"where": where, "kind": kind, "residual_mm": round(rms * 1000, 2), "noise_mm": round(noise * 1000, 2),
                     "ratio": round(rms / noise, 1), "frames": frames, "segments": count}
            if figure is not None:
                entry["figure"] = figure.name
            found.append(entry)
    found.sort(key=lambda e: (e["kind"] != "all", -e["ratio"]))
    if figure is not None:
        _draw(judged, res, noise, geometry, figure)
    return found


def _draw(judged, res: Residuals, noise: float, geometry: TableGeometry, path: Path) -> None:
    fig, (ax_map, ax_bars) = plt.subplots(1, 2, figsize=(11, 5.2), gridspec_kw={"width_ratios": [1, 1.5]})
    hx, hy = geometry.half_width, geometry.half_length
    regions = [(where, mask, rms, enough) for kind, where, mask, rms, _f, _c, enough in judged if kind == "region"]
    for _where, mask, rms, enough in regions:
        if not mask.any():
            continue
        x0, x1 = res.xy[mask, 0].min(), res.xy[mask, 0].max()
        y0, y1 = res.xy[mask, 1].min(), res.xy[mask, 1].max()
        cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
        colour = plt.cm.Reds(min(rms / noise / (2 * FAR_ABOVE), 1.0)) if enough else (0.85, 0.85, 0.85, 1.0)
        ax_map.add_patch(plt.Rectangle((x0, y0), x1 - x0, y1 - y0, color=colour, alpha=0.8))
        ax_map.text(cx, cy, f"{rms / noise:.1f}" if enough else "-", ha="center", va="center", fontsize=8)
    ax_map.plot([-hx, hx, hx, -hx, -hx], [-hy, -hy, hy, hy, -hy], "k-", lw=1)
    ax_map.set_xlim(-hx - 0.02, hx + 0.02)
    ax_map.set_ylim(-hy - 0.02, hy + 0.02)
    ax_map.set_aspect("equal")
    ax_map.set_xlabel("x (m)")
    ax_map.set_ylabel("y (m)")
    ax_map.set_title("residual RMS / noise where the rolls were")
    others = [(where, rms, enough) for kind, where, _m, rms, _f, _c, enough in judged if kind in ("all", "speed", "event")]
    labels = [w.replace("the first ", "").replace(" m/s", "") for w, _r, _e in others]
    ratios = [r / noise if e else 0.0 for _w, r, e in others]
    colours = ["tab:red" if r > FAR_ABOVE else "tab:blue" for r in ratios]
    ax_bars.barh(range(len(others)), ratios, color=colours)
    ax_bars.axvline(FAR_ABOVE, color="k", ls="--", lw=1, label=f"{FAR_ABOVE:g} x noise: unexplained beyond")
    ax_bars.axvline(1.0, color="grey", ls=":", lw=1, label="the noise")
    ax_bars.set_yticks(range(len(others)), labels, fontsize=8)
    ax_bars.invert_yaxis()
    ax_bars.set_xlabel("residual RMS / detection noise (0: too little data)")
    ax_bars.legend(fontsize=8, loc="lower right")
    ax_bars.set_title(f"detection noise {noise * 1000:.2f} mm")
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def prediction_floor(starts: Sequence[Start], thetas: Sequence[np.ndarray], noise: float, seed: int = 0) -> np.ndarray:
    """Median error (m) at each of HORIZONS that a right model would make from the detection noise alone.

    Each start's history is replaced by its model's own path through it (the fitted start, no noise),
    redrawn FLOOR_DRAWS times with Gaussian noise of the measured size, the start re-estimated from
    each draw as `evaluate.estimate_states` does, and carried forward by the same model (the surrogate,
    without walls: a bounce changes where the error is, not how large it is); the detection it is compared with
    carries the noise too.
    """
    if not starts:
        return np.full(len(HORIZONS), np.nan)
    rng = np.random.default_rng(seed)
    thetas = [np.asarray(t, dtype=float) for t in thetas]
    paths = []
    for i, start in enumerate(starts):
        batch = SegmentBatch([start.history])
        fitted = fit_states(batch, thetas[i])
        paths.append(batch.predict(fitted.states, thetas[i][None, :])[0, : len(start.history.t)])
    clean = estimate_states([_with_xy(s, p) for s, p in zip(starts, paths)], thetas)
    theta_rows = np.stack(thetas)
    errors = []
    for _ in range(FLOOR_DRAWS):
        noisy = [_with_xy(s, p + rng.normal(0.0, noise, p.shape)) for s, p in zip(starts, paths)]
        drawn = estimate_states(noisy, thetas)
        row = []
        for h in HORIZONS:
            duration = np.full(len(starts), h)
            p_true, _ = surrogate.integrate_state(clean[:, :2], clean[:, 2:], theta_rows, duration, DT)
            p_drawn, _ = surrogate.integrate_state(drawn[:, :2], drawn[:, 2:], theta_rows, duration, DT)
            seen = p_true + rng.normal(0.0, noise, p_true.shape)
            row.append(np.linalg.norm(p_drawn - seen, axis=1))
        errors.append(np.stack(row, axis=1))
    return np.median(np.concatenate(errors), axis=0)


def _with_xy(start: Start, xy: np.ndarray) -> Start:
    history = start.history
    return Start(start.track, start.t0, Segment(history.track, history.flight, history.t, xy), start.fold)


def unexplained_predictions(errors: np.ndarray, floor: np.ndarray, noise: float, label: str) -> list[dict]:
    """An entry when the held-out predictions miss by far more than a right model would (see the module).

    Judged at the longest horizon with MIN_PREDICTION_STARTS starts measured: 1 s on rolls; in a game, where
    figures leave few stretches that long, a shorter one.
    """
    for j in reversed(range(len(HORIZONS))):
        e = errors[:, j]
        e = e[np.isfinite(e)]
        if len(e) >= MIN_PREDICTION_STARTS and np.isfinite(floor[j]):
            break
    else:
        return []
    median = float(np.median(e))
    if median <= FAR_ABOVE * floor[j]:
        return []
    return [{"where": f"predictions {HORIZONS[j]:g} s ahead from held-out starts ({label} model)", "kind": "prediction",
             "residual_mm": round(median * 1000, 2), "noise_mm": round(float(floor[j]) * 1000, 2),
             "ratio": round(median / float(floor[j]), 1), "starts": int(len(e)),
             "detection_noise_mm": round(noise * 1000, 2),
             "note": f"noise_mm here is the median error a right model makes {HORIZONS[j]:g} s ahead from the detection noise "
                     "alone"}]
