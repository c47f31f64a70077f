"""A generic correction for a surface the vocabulary cannot name: a smooth height map fitted to the rolls.

A table can be wrong in ways the contract has no name for (a bowl, a warped top, a lifted corner). The
named effects cannot take such a shape up, so it stays in the residuals. This module fits what a
smooth surface would have to be to explain them, without naming a cause: a height map h(x, y), a
sum of Gaussian bumps on a grid over the field, whose slope pulls a rolling ball at -5/7 g grad h.

The fit is linear. Along each rolling segment the calibrated model's own path p(t) is kept, and each
bump's pull along that path is integrated twice: the displacement it alone would add. The measured
residual (detections less the model) is then a sum of those displacements, plus a start position and
velocity of the segment's own (the model's start is itself a fit, which a smooth misfit partly hides
in): both are projected out per segment, and the bumps' heights follow from one ridge-regularised
least-squares solve (prior: heights of PRIOR_HEIGHT, so unvisited cells stay flat).

Its gain is judged as every named effect's is: on held-out data. The heights are fitted on one fold
of segments and judged on the other: each held-out segment's start is fitted on its own detections, with
and without the correction, and the RMS position error over all held-out samples compared (a start taken
from a segment's first 0.25 s alone drowned a 2 mm bowl in the start's own noise: segments between wall
bounces last 0.9 s on average). The correction is reported (under `unexplained`, with where and how much)
only where the drop's 95 % block-bootstrap interval excludes zero and the drop is at least
MIN_DROP_NOISE of the detection noise. The calibrated parameter file and the `calibrated` errors stay
those of the named effects; the correction's own errors sit beside them.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

import numpy as np
from scipy.integrate import cumulative_trapezoid

from foos_core.table_geometry import TableGeometry

from .effect_gain import drop_interval, excludes_zero
from .fitting import Fit, SegmentBatch
from .surrogate import ROLL, G
from .tracks import Segment

GRID = (5, 9)  # bumps across (x) and along (y) the field: about 0.17 x 0.15 m apart on the regulation table
PRIOR_HEIGHT = 0.0003  # m: a bump's prior scale (ridge); neighbouring bumps overlap, so a map of a few mm is many bumps' sum
MIN_DROP_NOISE = 0.02  # a floor under a drop that is significant but negligible: this share of the noise std
MAP_STEP = 0.02  # m, the grid the reported height map is evaluated on
FIGURE_FILE = "surface_correction.png"


@dataclass
class HeightMap:
    """Gaussian bumps on a grid: h(p) = sum_k c_k exp(-|p - q_k|^2 / (2 s^2))."""

    centres: np.ndarray  # (K, 2) m
    width: float  # s, m
    heights: np.ndarray  # (K,) m

    @classmethod
    def grid(cls, geometry: TableGeometry, shape: tuple[int, int] = GRID) -> "HeightMap":
        xs = np.linspace(-geometry.half_width, geometry.half_width, shape[0])
        ys = np.linspace(-geometry.half_length, geometry.half_length, shape[1])
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        spacing = max(xs[1] - xs[0], ys[1] - ys[0])
        return cls(np.stack([gx.ravel(), gy.ravel()], axis=1), float(spacing), np.zeros(gx.size))

    def bumps(self, p: np.ndarray) -> np.ndarray:
        """(N, K) each bump's height per unit coefficient at the points p (N, 2)."""
        d2 = ((p[:, None, :] - self.centres[None, :, :]) ** 2).sum(axis=2)
        return np.exp(-d2 / (2 * self.width**2))

    def pulls(self, p: np.ndarray) -> np.ndarray:
        """(N, K, 2) each bump's pull on a rolling ball, -5/7 g grad h, per unit coefficient."""
        diff = p[:, None, :] - self.centres[None, :, :]
        grad = -diff / self.width**2 * self.bumps(p)[:, :, None]
        return -ROLL * G * grad

    def height(self, p: np.ndarray) -> np.ndarray:
        return self.bumps(p) @ self.heights

    def pull(self, p: np.ndarray) -> np.ndarray:
        return np.einsum("nkd,k->nd", self.pulls(p), self.heights)


@dataclass
class _Piece:
    """One segment, linearised about the calibrated model's path."""

    segment: int
    group: int  # its track: the bootstrap's block
    fold: int
    tau: np.ndarray  # (m,) s since its start
    residual: np.ndarray  # (m, 2) detection - model, m
    response: np.ndarray  # (m, 2, K) the displacement each bump adds along the path, per unit height


def _pieces(segments: Sequence[Segment], fit: Fit, heights: HeightMap) -> list[_Piece]:
    batch = SegmentBatch(segments)
    prediction = batch.predict(fit.states, np.tile(fit.theta, (batch.n, 1)))
    pieces = []
    for i, segment in enumerate(batch.segments):
        m = int(batch.mask[i].sum())
        if m < 8:
            continue
        tau = batch.tau[i, :m]
        path = prediction[i, :m]
        pull = heights.pulls(path)  # (m, K, 2)
        velocity = cumulative_trapezoid(pull, tau, axis=0, initial=0.0)
        displacement = cumulative_trapezoid(velocity, tau, axis=0, initial=0.0)
        pieces.append(_Piece(i, segment.track, segment.fold, tau, batch.meas[i, :m] - path,
                             np.transpose(displacement, (0, 2, 1))))
    return pieces


def _start_basis(tau: np.ndarray) -> np.ndarray:
    """(m, 2, 4): a start position and velocity per axis (x0, y0, vx0, vy0)."""
    basis = np.zeros((len(tau), 2, 4))
    basis[:, 0, 0] = basis[:, 1, 1] = 1.0
    basis[:, 0, 2] = basis[:, 1, 3] = tau
    return basis


def _project_out_start(rows: np.ndarray, basis: np.ndarray) -> np.ndarray:
    """rows (m*2, c) less their least-squares fit by the start basis (m*2, 4)."""
    coef, *_ = np.linalg.lstsq(basis, rows, rcond=None)
    return rows - basis @ coef


def fit_heights(pieces: Sequence[_Piece], heights: HeightMap, noise: float) -> np.ndarray:
    """The bumps' heights (K,) that best explain the pieces' residuals, each piece's start free."""
    k = len(heights.heights)
    normal = np.zeros((k, k))
    rhs = np.zeros(k)
    for piece in pieces:
        basis = _start_basis(piece.tau).reshape(-1, 4)
        columns = np.concatenate([piece.response.reshape(-1, k), piece.residual.reshape(-1, 1)], axis=1)
        projected = _project_out_start(columns, basis)
        a, b = projected[:, :k], projected[:, k]
        normal += a.T @ a
        rhs += a.T @ b
    ridge = (max(noise, 1e-4) / PRIOR_HEIGHT) ** 2
    return np.linalg.solve(normal + ridge * np.eye(k), rhs)


def held_out_error(piece: _Piece, correction: np.ndarray | None) -> float:
    """Mean squared position error (m^2) of a held-out segment, its start (position and velocity) fitted on its
    own detections, as the selection's fold evidence fits each segment's start: what the map explains is the
    bend of the path that no start can take up."""
    residual = piece.residual if correction is None else piece.residual - piece.response @ correction
    basis = _start_basis(piece.tau).reshape(-1, 4)
    coef, *_ = np.linalg.lstsq(basis, residual.reshape(-1), rcond=None)
    return float(np.mean((residual.reshape(-1) - basis @ coef) ** 2))


@dataclass
class SurfaceCorrection:
    heights: HeightMap  # fitted on all the segments
    gain: dict  # drop_interval's block (mm), held out by folds
    reported: bool

    def summary(self) -> dict:
        """What report.json keeps of every correction tried, reported or not."""
        return {"reported": bool(self.reported), "kind": "surface_height_map",
                "gain": {"held_out_error_mm": self.gain},
                "rule": f"reported when the held-out drop's 95 % interval excludes zero and the drop is at least "
                        f"{MIN_DROP_NOISE:g} of the detection noise"}

    def entry(self, noise: float, geometry: TableGeometry, figure: str | None) -> dict:
        """The `unexplained` entry: where and how much, and the gain it would bring."""
        xs = np.arange(-geometry.half_width, geometry.half_width + 1e-9, MAP_STEP)
        ys = np.arange(-geometry.half_length, geometry.half_length + 1e-9, MAP_STEP)
        gx, gy = np.meshgrid(xs, ys, indexing="ij")
        h = self.heights.height(np.stack([gx.ravel(), gy.ravel()], axis=1)).reshape(gx.shape)
        low, high = np.unravel_index(np.argmin(h), h.shape), np.unravel_index(np.argmax(h), h.shape)
        span = float(h.max() - h.min())
        without = self.gain["without"]
        return {
            "where": (f"the surface: a smooth height map outside the vocabulary, {span * 1000:.1f} mm from its lowest point "
                      f"(x {xs[low[0]]:+.2f}, y {ys[low[1]]:+.2f} m) to its highest (x {xs[high[0]]:+.2f}, y {ys[high[1]]:+.2f} m)"),
            "kind": "surface_height_map",
            "residual_mm": without, "noise_mm": round(noise * 1000, 2),
            "ratio": round(without / (noise * 1000), 2) if noise > 0 else None,
            "height_span_mm": round(span * 1000, 2),
            "lowest_xy": [round(float(xs[low[0]]), 3), round(float(ys[low[1]]), 3)],
            "highest_xy": [round(float(xs[high[0]]), 3), round(float(ys[high[1]]), 3)],
            "gain": {"held_out_error_mm": self.gain},
            "corrected_error_mm": self.gain["with"],
            "map": {"x": [round(float(v), 3) for v in xs[::5]], "y": [round(float(v), 3) for v in ys[::5]],
                    "height_mm": np.round(h[::5, ::5] * 1000, 2).tolist()},
            **({"figure": figure} if figure else {}),
            "cause": "not named: the shape is measured, its cause (a bowl, a warp, a lifted board) is not proven",
        }


def fit_surface_correction(segments: Sequence[Segment], fit: Fit, noise: float, geometry: TableGeometry,
                           seed: int = 0) -> SurfaceCorrection | None:
    """The correction and its held-out gain; None where the segments are too few to judge one."""
    if len(segments) < 6:
        return None
    template = HeightMap.grid(geometry)
    pieces = _pieces(segments, fit, template)
    folds = sorted({p.fold for p in pieces})
    if len(folds) < 2:
        return None
    without, with_, groups, weights = [], [], [], []
    for fold in folds:
        train = [p for p in pieces if p.fold != fold]
        correction = fit_heights(train, template, noise)
        for piece in (p for p in pieces if p.fold == fold):
            without.append(held_out_error(piece, None))
            with_.append(held_out_error(piece, correction))
            groups.append(piece.group)
            weights.append(len(piece.tau))
    gain = drop_interval(np.array(without), np.array(with_), np.array(groups), seed=seed, scale=1000.0,
                         weights=np.array(weights, dtype=float))
    heights = HeightMap(template.centres, template.width, fit_heights(pieces, template, noise))
    material = gain.get("drop") is not None and gain["drop"] >= MIN_DROP_NOISE * noise * 1000
    reported = excludes_zero(gain) and material
    return SurfaceCorrection(heights, gain, reported)


def draw(correction: SurfaceCorrection, geometry: TableGeometry, path: Path) -> None:
    """The fitted height map over the field, in mm."""
    import matplotlib  # here: only the figure needs it

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt  # here too: the figure alone needs it

    xs = np.linspace(-geometry.half_width, geometry.half_width, 69)
    ys = np.linspace(-geometry.half_length, geometry.half_length, 121)
    gx, gy = np.meshgrid(xs, ys, indexing="ij")
    h = correction.heights.height(np.stack([gx.ravel(), gy.ravel()], axis=1)).reshape(gx.shape) * 1000
    fig, ax = plt.subplots(figsize=(4.5, 6.5))
    image = ax.pcolormesh(gx, gy, h, shading="auto", cmap="RdBu_r")
    fig.colorbar(image, ax=ax, label="height, mm")
    ax.set_aspect("equal")
    ax.set_xlabel("x, m")
    ax.set_ylabel("y, m")
    g = correction.gain
    ax.set_title(f"surface correction, no cause named\nheld-out error {g.get('without')} -> {g.get('with')} mm", fontsize=9)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
