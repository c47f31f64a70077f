"""Finding the ball in a frame: a colour model, a size prior from the homography, sub-pixel centres.

The colour model is a box in OpenCV's 8-bit Lab space (lightness range, a/b centre and half width),
widened for coloured balls by a hue band with a saturation floor (OpenCV HSV): hue and saturation do not
change when a surface is shaded, so the dark underside of the ball, which leaves the Lab box, stays in.
Named colours start from a broad prototype; `learn` narrows it to the pixels of confidently detected
balls, so the model ends up fitted to the real ball under the real lights. `auto` tries each named
prototype on the first frames and keeps the one that finds a ball-sized, round blob most often.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Callable, Optional

import cv2
import numpy as np

from .components import components_with_stats
from .streaks import Streak

BALL_COLOR_NAMES = ("white", "yellow", "orange", "red")
# A blob merged with something of the ball's colour holds a ball only where it is at least this thick (radii
# of the largest disc inside). A ball half hidden by a rod it touches keeps half its radius; a rod or a line
# is a few pixels thick.
MERGED_MIN_PEAK = 0.45
# A ball behind a rod is judged on the part of its disc in view while at most this share of the disc is hidden;
# beyond it, what shows is a sliver a pixel or two thick on these cameras, judged as a sliver. (0.5 cost 0.6-1.4 points
# of recall in five of the 28 bench videos; 0.7 moved their p95 by -0.1 to +0.3 mm.)
MAX_HIDDEN_SHARE = 0.7
FELT_AB_TOL = 14  # Lab a/b distance from the felt's median within which a pixel is bare felt (in light or shadow)


@dataclass(frozen=True)
class ColourModel:
    name: str
    l_min: int
    l_max: int
    a: float
    b: float
    ab_tol: float  # half width of the a/b box
    # Shading-tolerant band (OpenCV HSV, hue 0-179): hue_lo > hue_hi wraps through 0 (red). None: no band
    # (a white ball has no hue; its shaded side is as grey as a steel rod).
    hue_lo: Optional[int] = None
    hue_hi: Optional[int] = None
    s_min: int = 170  # the felt, wood, skin and painted figures are less saturated than a coloured ball
    v_min: int = 45  # below this, hue is noise

    def box_mask(self, lab: np.ndarray) -> np.ndarray:
        lo = (self.l_min, max(0, int(self.a - self.ab_tol)), max(0, int(self.b - self.ab_tol)))
        hi = (self.l_max, min(255, int(self.a + self.ab_tol)), min(255, int(self.b + self.ab_tol)))
        return cv2.inRange(lab, lo, hi)

    def band_mask(self, bgr: np.ndarray) -> Optional[np.ndarray]:
        """Pixels of the ball's hue and saturation at any lightness (None for a model without a band)."""
        if self.hue_lo is None or self.hue_hi is None:
            return None
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        if self.hue_lo <= self.hue_hi:
            return cv2.inRange(hsv, (self.hue_lo, self.s_min, self.v_min), (self.hue_hi, 255, 255))
        return (cv2.inRange(hsv, (self.hue_lo, self.s_min, self.v_min), (179, 255, 255))
                | cv2.inRange(hsv, (0, self.s_min, self.v_min), (self.hue_hi, 255, 255)))

    def mask(self, lab: np.ndarray, bgr: Optional[np.ndarray] = None) -> np.ndarray:
        box = self.box_mask(lab)
        band = None if bgr is None else self.band_mask(bgr)
        return box if band is None else box | band


# Prototypes from the reflectance of typical balls under neutral light: broad on purpose. The hue bands
# split the hue circle between the three coloured balls (red 168-9, orange 8-21, yellow 20-40), so auto
# still tells them apart.
PROTOTYPES = {
    "white": ColourModel("white", 150, 255, 128, 130, 14),
    "yellow": ColourModel("yellow", 90, 255, 122, 192, 26, hue_lo=20, hue_hi=40),
    "orange": ColourModel("orange", 60, 255, 160, 185, 22, hue_lo=8, hue_hi=21),
    "red": ColourModel("red", 50, 230, 185, 165, 24, hue_lo=168, hue_hi=9),
}


def colour_model(name: str) -> ColourModel:
    if name not in PROTOTYPES:
        raise ValueError(f"unknown ball colour `{name}` (one of auto, {', '.join(BALL_COLOR_NAMES)})")
    return PROTOTYPES[name]


def learn_colour(model: ColourModel, lab_pixels: np.ndarray) -> ColourModel:
    """The model narrowed to the Lab pixels of confidently detected balls (N, 3)."""
    if len(lab_pixels) < 30:
        return model
    lab_pixels = lab_pixels.astype(float)
    # The core pixels are the ball's most saturated; its rim blends into the felt and must stay inside the
    # box for an unbiased centre. So the box follows the ball's hue, but only by half its width, and
    # only ever grows.
    shift = np.clip(np.median(lab_pixels[:, 1:], axis=0) - (model.a, model.b), -model.ab_tol / 2, model.ab_tol / 2)
    a, b = model.a + shift[0], model.b + shift[1]
    spread = np.percentile(np.abs(lab_pixels[:, 1:] - (a, b)), 90, axis=0).max()
    tol = float(max(model.ab_tol, min(1.5 * spread + 4, 40)))
    # The core is the lit part of the ball; its shaded rim is darker, so lightness is only ever relaxed.
    l_min = int(min(model.l_min, max(20.0, np.percentile(lab_pixels[:, 0], 3) - 15)))
    return replace(model, a=float(a), b=float(b), ab_tol=tol, l_min=l_min)


@dataclass
class Candidate:
    u: float  # sub-pixel centre, distorted image pixels
    v: float
    area_ratio: float  # visible pixels / expected disc area
    roundness: float  # 1 for a disc, lower for streaks and bars
    score: float
    spill: float = 0.0  # blob pixels 1.25-1.8 radii from the centre / expected disc area: ~0 for a lone ball
    fill: float = 1.0  # share of the inner disc (0.7 radii) that is ball-coloured: ~1 for a ball in view
    # Share of the disc behind something known to be in front of the ball (a steel rod); area_ratio, fill and
    # roundness are then taken over the rest.
    hidden: float = 0.0
    # A motion-blurred ball (streaks.find_streaks): its centre is the ball at mid-exposure, area_ratio the shares of
    # the exposure seen over the disc. None: a ball seen as a disc (or part of one).
    streak: Optional[Streak] = None


def _refine_centre(mask: np.ndarray, u: float, v: float, radius: float) -> tuple[float, float, float]:
    """Centroid of the mask inside a disc around (u, v), iterated; returns (u, v, pixel count)."""
    h, w = mask.shape
    count = 0.0
    for _ in range(3):
        x0, x1 = max(0, int(u - 1.4 * radius)), min(w, int(u + 1.4 * radius) + 2)
        y0, y1 = max(0, int(v - 1.4 * radius)), min(h, int(v + 1.4 * radius) + 2)
        if x1 <= x0 or y1 <= y0:
            break
        sub = mask[y0:y1, x0:x1]
        yy, xx = np.nonzero(sub)
        if len(xx) == 0:
            break
        xx = xx + x0
        yy = yy + y0
        near = (xx - u) ** 2 + (yy - v) ** 2 <= (1.3 * radius) ** 2
        if not np.any(near):
            break
        u, v, count = float(xx[near].mean()), float(yy[near].mean()), float(near.sum())
    return u, v, count


def _fit_known_radius(mask: np.ndarray, u: float, v: float, radius: float,
                      edge_radius: Optional[float] = None) -> tuple[float, float]:
    """Centre of a partly hidden disc: fit a circle of the expected radius to its outline pixels.

    Outline pixels on the occluder's edge lie well inside the circle; a Tukey weight ignores them.
    """
    h, w = mask.shape
    r = int(1.6 * radius) + 2
    x0, y0 = max(0, int(u) - r), max(0, int(v) - r)
    sub = np.ascontiguousarray(mask[y0:min(h, int(v) + r + 1), x0:min(w, int(u) + r + 1)])
    contours, _ = cv2.findContours(sub, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    if not contours:
        return u, v
    points = max(contours, key=len).reshape(-1, 2).astype(float) + (x0, y0)
    if len(points) < 8:
        return u, v
    c = np.array([u, v])
    # Outline pixel centres sit half a pixel inside the mask's edge, which may itself lie inside the ball's outline.
    target = (radius if edge_radius is None else edge_radius) - 0.5
    for _ in range(8):
        d = points - c
        dist = np.maximum(np.linalg.norm(d, axis=1), 1e-6)
        residual = dist - target
        scale = max(1.0, 0.25 * radius)
        weight = np.where(np.abs(residual) < 2.5 * scale, (1 - (residual / (2.5 * scale)) ** 2) ** 2, 0.0)
        if weight.sum() < 4:
            break
        # Gauss-Newton on sum w (|p - c| - r)^2 with respect to c.
        jac = -d / dist[:, None]
        a = (jac * weight[:, None]).T @ jac
        g = (jac * weight[:, None]).T @ residual
        try:
            step = -np.linalg.solve(a + 1e-6 * np.eye(2), g)
        except np.linalg.LinAlgError:
            break
        c = c + step
        if np.linalg.norm(step) < 0.01:
            break
    return float(c[0]), float(c[1])


def _fit_disc_to_view(mask: np.ndarray, felt: np.ndarray, u: float, v: float, radius: float,
                      edge_radius: float) -> tuple[float, float]:
    """Centre of a partly hidden ball: where a disc of the mask's edge radius best matches what is seen, in least
    squares over the pixels whose colour says what they are: the ball's (mask) or the bare felt's (felt).

    Everything else (a rod, a wall, a figure, the ball's own dark rim) is unknown and does not count, so the
    occluder's edge is not taken for the ball's outline, and a short arc cannot slide: where the disc would
    show felt, it is wrong. The cost sum_known (disc - ball)^2 is, up to a constant, two correlations of the
    disc with the known and the ball pixels, so every whole-pixel centre within a radius of (u, v) costs one
    filter; the best is then refined on a quarter-pixel grid."""
    h, w = mask.shape
    reach = int(math.ceil(2 * radius)) + 3
    x0, y0 = max(0, int(u) - reach), max(0, int(v) - reach)
    x1, y1 = min(w, int(u) + reach + 1), min(h, int(v) + reach + 1)
    ball = (mask[y0:y1, x0:x1] > 0).astype(np.float32)
    if not np.any(ball):
        return u, v
    known = np.maximum(ball, (felt[y0:y1, x0:x1] > 0).astype(np.float32))
    k = int(math.ceil(edge_radius + 1))
    ky, kx = np.mgrid[-k:k + 1, -k:k + 1]
    disc = np.clip(edge_radius + 0.5 - np.hypot(kx, ky), 0.0, 1.0).astype(np.float32)  # edge pixels partly covered
    cost = (cv2.filter2D(known, -1, disc * disc, borderType=cv2.BORDER_CONSTANT)
            - 2.0 * cv2.filter2D(ball, -1, disc, borderType=cv2.BORDER_CONSTANT))
    ys, xs = np.mgrid[y0:y1, x0:x1]
    cost[(xs - u) ** 2 + (ys - v) ** 2 > radius * radius] = np.inf
    j, i = np.unravel_index(int(np.argmin(cost)), cost.shape)
    best = np.array([x0 + i, y0 + j], dtype=np.float32)
    near = (xs - best[0]) ** 2 + (ys - best[1]) ** 2 <= (edge_radius + 2) ** 2
    on = near & (known > 0)
    px, py, seen = xs[on].astype(np.float32), ys[on].astype(np.float32), ball[on]
    offsets = np.arange(-1.0, 1.01, 0.25, dtype=np.float32)
    cu = (best[0] + offsets)[:, None, None]
    cv_ = (best[1] + offsets)[None, :, None]
    fine = np.clip(edge_radius + 0.5 - np.sqrt((px - cu) ** 2 + (py - cv_) ** 2), 0.0, 1.0)
    a, b = np.unravel_index(int(np.argmin(((fine - seen) ** 2).sum(axis=2))), (len(offsets), len(offsets)))
    return float(best[0] + offsets[a]), float(best[1] + offsets[b])


def _ring_pixels(mask: np.ndarray, u: float, v: float, inner: float, outer: float) -> int:
    """Mask pixels between two radii around (u, v): a blob that goes on past the ball's outline is, or
    touches, something else of its colour (a figure, a hand)."""
    h, w = mask.shape
    x0, y0 = max(0, int(u - outer)), max(0, int(v - outer))
    x1, y1 = min(w, int(u + outer) + 2), min(h, int(v + outer) + 2)
    ys, xs = np.nonzero(mask[y0:y1, x0:x1])
    d2 = (xs + x0 - u) ** 2 + (ys + y0 - v) ** 2
    return int(np.count_nonzero((d2 > inner * inner) & (d2 <= outer * outer)))


def _disc(shape: tuple[int, int], u: float, v: float, radius: float) -> np.ndarray:
    ys, xs = np.ogrid[0:shape[0], 0:shape[1]]
    return (xs - u) ** 2 + (ys - v) ** 2 <= radius * radius


def _disc_pixels(mask: np.ndarray, u: float, v: float, radius: float) -> int:
    """Non-zero pixels of mask within radius of (u, v)."""
    return _ring_pixels(mask, u, v, -1.0, radius)


class BallDetector:
    """Candidates for the ball in a region of a frame, with centres and quality measures."""

    def __init__(self, model: ColourModel, edge_scale: float = 1.0):
        self.model = model
        # The colour mask's edge over the ball's radius: the rim blends into the felt, and a white ball's shaded
        # side leaves its box, so the mask of a whole ball is a smaller disc (0.85 of the radius for the white
        # renders). A partly hidden ball is fitted as a disc of this radius, not of the ball's.
        self.edge_scale = edge_scale

    def candidates(self, bgr: np.ndarray, roi: tuple[int, int, int, int], radius_at: Callable[[float, float], float],
                   min_radius: float, region_mask: Optional[np.ndarray] = None, bridge_px: int = 0,
                   use_band: bool = True, band_seeds: bool = False, fit_outline: bool = True,
                   hidden: Optional[np.ndarray] = None,
                   felt_ab: Optional[tuple[float, float]] = None) -> tuple[list[Candidate], np.ndarray, np.ndarray]:
        """Candidates inside roi = (x0, y0, x1, y1); radius_at(u, v) is the expected ball radius in pixels
        at a full-frame pixel. Also returns the roi's Lab image and colour mask.

        Blobs start from the Lab box. The hue band (shaded ball pixels) only completes a blob's disc when
        its centre is measured, unless band_seeds: a wooden frame or a dark figure can share the ball's hue
        and saturation, so band pixels alone found a blob only where the caller expects the ball.
        fit_outline=False is a coarse search whose finds are measured again anyway: no known-radius fit
        of partly hidden or merged blobs, and no fill or spill (left at 1 and 0).
        hidden: full-frame uint8, non-zero where something known is in front of the ball (the steel rods): a
        ball partly behind it is measured on what is left of its disc, as a partial view of a whole ball, not
        as a smaller or thinner blob. felt_ab: the bare felt's Lab a and b; given, a partly hidden ball's centre
        is fitted to the ball and felt pixels around it (_fit_disc_to_view), else to its outline."""
        x0, y0, x1, y1 = roi
        lab = cv2.cvtColor(bgr[y0:y1, x0:x1], cv2.COLOR_BGR2Lab)
        box = self.model.box_mask(lab)
        band = self.model.band_mask(bgr[y0:y1, x0:x1]) if use_band else None
        if region_mask is not None:
            box &= region_mask[y0:y1, x0:x1]
            if band is not None:
                band &= region_mask[y0:y1, x0:x1]
        mask = box if band is None else box | band
        grouping = mask if band_seeds else box
        if bridge_px > 0:
            # A rod across the ball cuts it in two crescents: group pixels across such a thin gap, but
            # measure the centre on the ball's own pixels only.
            kernel = cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * bridge_px + 1, 2 * bridge_px + 1))
            grouping = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, kernel)
        n, labels, stats, centroids = components_with_stats(grouping)
        found: list[Candidate] = []
        for i in range(1, n):
            area = stats[i, cv2.CC_STAT_AREA]
            if area < max(3.0, 0.2 * math.pi * min_radius**2):
                continue
            radius_px = radius_at(centroids[i][0] + x0, centroids[i][1] + y0)
            expected = math.pi * radius_px**2
            bw, bh = stats[i, cv2.CC_STAT_WIDTH], stats[i, cv2.CC_STAT_HEIGHT]
            bx, by = stats[i, cv2.CC_STAT_LEFT], stats[i, cv2.CC_STAT_TOP]
            pad = int(2 * radius_px) + 2
            wx0, wy0 = max(0, bx - pad), max(0, by - pad)
            local = (labels[wy0:by + bh + pad, wx0:bx + bw + pad] == i).astype(np.uint8)
            if bridge_px > 0:
                local &= (mask[wy0:by + bh + pad, wx0:bx + bw + pad] > 0).astype(np.uint8)
                area = int(local.sum())
                if area < 3:
                    continue
            u, v = centroids[i][0] - wx0, centroids[i][1] - wy0
            if area > 1.8 * expected or max(bw, bh) > 3.2 * radius_px:
                # Merged with something of the same colour (a rod, a line, a hand): the ball is where the
                # blob is thickest.
                dist = cv2.distanceTransform(local, cv2.DIST_L2, 3)
                peak = float(dist.max())
                if peak < MERGED_MIN_PEAK * radius_px:
                    continue
                py, px = np.unravel_index(int(np.argmax(dist)), dist.shape)
                u, v = float(px), float(py)
            u, v, count = _refine_centre(local, float(u), float(v), radius_px)
            if band is not None and not band_seeds:
                # The shaded part of the disc is in the band, not the box: measure on both, unless that
                # brings in more than a ball's worth of pixels (the ball against something of its hue).
                whole = (mask[wy0:wy0 + local.shape[0], wx0:wx0 + local.shape[1]] > 0).astype(np.uint8) | local
                uw, vw, cw = _refine_centre(whole, u, v, radius_px)
                if count <= cw <= 1.15 * expected:
                    local, u, v, count = whole, uw, vw, cw
            ratio = count / expected
            if ratio < 0.25:
                continue
            behind = None
            if hidden is not None and fit_outline:
                behind = hidden[y0 + wy0:y0 + wy0 + local.shape[0], x0 + wx0:x0 + wx0 + local.shape[1]]
                if not np.any(behind):
                    behind = None
            merged = fit_outline and _ring_pixels(local, u, v, 1.25 * radius_px, 1.8 * radius_px) > 0.15 * expected
            if fit_outline and (ratio < 0.8 or merged):
                # Partly hidden, or touching something of its colour (a figure): the pixels that are not the
                # ball would pull a centroid. A partly hidden ball is the disc that best explains the ball and
                # felt pixels around it; one merged with something of its colour is the outline's circular part.
                if felt_ab is not None and not merged:
                    lab_local = lab[wy0:wy0 + local.shape[0], wx0:wx0 + local.shape[1]].astype(np.int16)
                    felt = ((np.abs(lab_local[..., 1] - felt_ab[0]) <= FELT_AB_TOL)
                            & (np.abs(lab_local[..., 2] - felt_ab[1]) <= FELT_AB_TOL))
                    u, v = _fit_disc_to_view(local, felt, u, v, radius_px, self.edge_scale * radius_px)
                else:
                    u, v = _fit_known_radius(local, u, v, radius_px, self.edge_scale * radius_px)
            hidden_share = 0.0
            shape = local
            if behind is not None:
                in_front = _disc_pixels(behind, u, v, radius_px)
                hidden_share = in_front / max(1.0, _disc_pixels(np.ones_like(behind), u, v, radius_px))
                if hidden_share > MAX_HIDDEN_SHARE:
                    hidden_share = 0.0
                if hidden_share > 0:
                    # The shape of what shows plus what is known to cover the rest: a disc for a ball behind a rod.
                    shape = local | ((behind > 0) & _disc(behind.shape, u, v, radius_px)).astype(np.uint8)
                    ratio = count / (expected * (1.0 - hidden_share))
            # Roundness from the second moments of the pixels near the centre: a streak or a bar is long.
            ys, xs = np.nonzero(shape[max(0, int(v - 1.5 * radius_px)):int(v + 1.5 * radius_px) + 2,
                                      max(0, int(u - 1.5 * radius_px)):int(u + 1.5 * radius_px) + 2])
            roundness = 1.0
            if len(xs) >= 5:
                ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(float)))
                roundness = float(math.sqrt(max(ev[0], 1e-6) / max(ev[1], 1e-6)))
            spill, fill = 0.0, 1.0
            if fit_outline:
                spill = _ring_pixels(local, u, v, 1.25 * radius_px, 1.8 * radius_px) / expected
                inner = math.pi * (0.7 * radius_px) ** 2
                if hidden_share > 0:
                    inner -= _disc_pixels(behind, u, v, 0.7 * radius_px)
                fill = _ring_pixels(local, u, v, -1.0, 0.7 * radius_px) / max(1.0, inner)
            u, v = u + wx0, v + wy0
            score = min(ratio, 1.0) * roundness - 0.5 * max(0.0, ratio - 1.3)
            found.append(Candidate(u + x0, v + y0, ratio, roundness, score, spill, fill, hidden_share))
        return found, lab, mask
