"""Motion-blurred balls: a ball that moves several of its widths while the shutter is open is a faint streak in a
mix of its colour and the felt's, which no colour box of the ball takes.

Each pixel of a frame is the mean of what it saw during the exposure: a share alpha of the ball's colour and the
rest felt, P = alpha * B + a * F (a is 1 - alpha times the felt's own brightness there, which its weave and the
lights change). With the ball's colour B (learned from the whole balls seen) and the felt's F (the bare felt's median
over the field), that is two numbers per pixel and a residual off the plane of B and F: a rod, a figure of another colour, a
wall, are off it or need a negative felt share, and are not known to be ball or felt.

The shares of a whole exposure add up to the ball's disc, wherever and however fast it went: sum(alpha) = pi r^2
(the ball's own shading aside, which is in its mean colour B). Their centroid is the ball's mean position over the
exposure, its centre at mid-exposure for a ball that keeps its velocity: the time the frame is stamped. Along the
streak's axis, the second moment adds the motion: var = r^2 / 4 + m^2 / 12 for a disc moved m, across it r^2 / 4.
A blob of such pixels is fitted with that model on the pixels known to be ball or felt (a rod or a figure over part
of the streak does not count), and the ball at mid-exposure is where half of its shares lie on either side.
A figure of the ball's colour is on the plane too, as solid ball colour: given the rods' axes, solid ball colour by an
axis is taken as hidden, like a figure of another colour, so a streak that touches it is measured without it. A figure's
outline blends it with the felt and passes for a faint share of the ball: a blob too wide or too solid for a ball is
grouped again by its pixels clear of anything hidden. A streak that a figure hides along one side is narrower than a
disc: it is fitted when the hidden pixels lie along that side, and is as wide as its fitted model.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import cv2
import numpy as np

from .components import components_with_stats

ALPHA_MIN = 0.05  # least share of the exposure a pixel must have seen the ball in (noise: 0.01 on yellow and felt)
RESIDUAL_MAX = 8.0  # 8-bit levels off the plane of the ball's and the felt's colours (noise 1.5, compression)
FELT_SCALE = (0.5, 1.8)  # the felt behind a mixed pixel, as bright as its median times this
SOLID_ALPHA = 0.85  # a pixel this much ball may have no felt behind it at all
# A blob worth fitting: its shares add up to MOMENT_SHARES of a disc (and, find_streaks' arguments, its second
# moments say it moved min_motion radii or more and is as wide as a disc).
MOMENT_SHARES = (0.3, 2.0)
# Nor a blob that is mostly the ball's solid colour (shares over SOLID_ALPHA on more than MAX_SOLID of its pixels): a
# figure or a hand of that colour. A ball that moved twice its radius or more covered no pixel for all the exposure,
# unless it rested for most of it.
MAX_SOLID = 0.3
# Nor one with a pixel that saw the ball all the exposure (MAX_PEAK of it, averaged over 3x3): the ball was not moving
# there, or it is something else of its colour (a red ball against a red figure). Kept out of the fits, which cost
# more than the rest of the search (on the red-lens case, 156 blobs of this kind were fitted and none taken).
MAX_PEAK = 0.95
# The ball share of a streak over that of the learned colour (the mean of a whole ball's inner disc, its lit part, is
# 1 / 0.89 of the whole disc's on the renders), and the weight of the fit's prior on it, per pixel.
CONTRAST, CONTRAST_WEIGHT = 0.9, 0.01
SMOOTHING = 0.4  # radii: the box the shares are averaged over for the fit (3 px at least)
REST_PEAK = 2.5  # a blob whose largest share is this many times its median is also fitted as a ball that rested
# A figure of the ball's colour is solid colour (shares over SOLID_ALPHA) over its rod's axis: the rod runs through its
# body, while the ball is always below the rods and never covers an axis. A streak that touches such a figure is one
# blob with it, too solid to be a streak: the figure's solid pixels, and FIGURE_MARGIN radii around them (its edges
# blend it with the felt), are taken as hidden, as the figure mask would have them, and the rest is measured.
# Solid ball colour within FIGURE_REACH radii of an axis is counted with the figure: a kicked leg reaches its foot's end
# 4.5 radii from the axis, and a figure's shaded middle (not its colour: unknown) can part its lit ends from the axis.
FIGURE_MARGIN, FIGURE_REACH = 0.3, 4.5
# A streak that something (a figure lying level) hides along one side is narrower than a disc by its moments: a blob
# CUT_WIDTH of a disc's spread or more is fitted when, CUT_PROBE px beyond its edge, CUT_SIDE of one side is hidden; its
# width is then the fitted streak's, the hidden shares the model's. 0.58 is 55 % of the disc's width seen: the path of
# the ball's centre is in view, so the fit places the streak across. Half of it (0.53), the path is a guess from an
# edge, and a line of felt blended with a rod or a figure along it reads so too (on the red-lens case: 0.51-0.54, 15
# radii long, explained 0.8-0.93, and only their colour, 6-10 levels off the plane, told them from a streak).
CUT_WIDTH, CUT_PROBE, CUT_SIDE = 0.58, 2.0, 0.5
# A ball of COARSE_RADIUS px or more is looked for at half resolution first (a quarter of the pixels): the window is
# searched at full resolution (as without this) only when a blob there passes the tests loosened by COARSE_SLACK, so
# the search finds what it found before or, where the half-resolution pass missed a streak, nothing. On goal5 (12 px)
# 6 of the 21 windows of the lost track are searched at full resolution, 7 ms a window at half against 22-26 at full.
COARSE_RADIUS, COARSE_SLACK = 10.0, 1.25


@dataclass(frozen=True)
class _Limits:
    """What _blobs keeps as a possible streak, and which groups it hands to the second grouping (crowded)."""
    shares: tuple[float, float]  # kept: the shares of this many discs
    min_motion: float  # kept: moved this many radii by the moments
    width: tuple[float, float]  # kept: spread across the axis over a disc's (below width[0]: cut, CUT_WIDTH)
    peak: float  # a blob with a share this high is solid: crowded
    solid: float  # as is one with more than this share of its pixels over SOLID_ALPHA
    solid_judged: bool  # a solid blob is still judged by its moments (else dropped)
    crowd_shares: float  # a blob with more shares than this many discs is crowded
    crowd_width: float  # as is one wider than this
    first: bool = False  # only whether there is one: the first blob kept ends the search
    # px beyond FIGURE_MARGIN hidden around a figure of the ball's colour; more than one: tried in turn, until one
    # keeps a blob
    figure_pads: tuple[float, ...] = (0.0,)

    @staticmethod
    def exact(min_motion: float, width: tuple[float, float]) -> "_Limits":
        return _Limits(MOMENT_SHARES, min_motion, width, MAX_PEAK, MAX_SOLID, False, MOMENT_SHARES[1], width[1])

    @staticmethod
    def coarse(min_motion: float, width: tuple[float, float]) -> "_Limits":
        """Looser everywhere, crowding sooner: averaging 2x2 pixels lowers a solid blob's peak and blurs a streak's
        edges, and a figure's blend with the felt may reach a pixel further (smoothed over 3x3 of the half
        resolution): the figures are hidden with their margin and, where that keeps no blob, a pixel more.
        Checked on every streak search of goal5 and of four renders, the pass forced at their 4-8 px radii: it said
        "maybe" in every window where full resolution found a streak (43 of 109 on shots-640-30-orange)."""
        k = COARSE_SLACK
        return _Limits((MOMENT_SHARES[0] / k, MOMENT_SHARES[1] * k), min_motion / k, (CUT_WIDTH / k, width[1] * k),
                       MAX_PEAK / k, MAX_SOLID / k, True, MOMENT_SHARES[1] / k, width[1] / k, first=True,
                       figure_pads=(0.0, 1.0))


@dataclass
class Streak:
    u: float  # the ball at mid-exposure: half the shares on either side along the axis (distorted image pixels)
    v: float
    area_ratio: float  # sum of the blob's shares (those over ALPHA_MIN) / the expected disc: the share of a disc seen
    axis: np.ndarray  # unit vector along the streak (pixels)
    motion: float  # pixels the ball moved during the exposure (the fit's)
    width_ratio: float  # spread of the shares across the axis / a disc's
    peak: float  # the largest share in the blob
    pixels: int
    contrast: float = 1.0  # the fitted model's ball share over the learned colour's
    explained: float = 1.0  # the share of the sum of squared shares around the streak that its fitted model explains
    cu: float = 0.0  # the shares' centroid, before the fit
    cv: float = 0.0
    radius: float = 1.0  # the ball's expected radius there (pixels)
    rest: float = 0.0  # the fitted share of the exposure the ball rested at one end (struck from rest, or stopped)
    # Medians over its pixels: the felt's brightness behind them over the median felt's (about 1 under a streak), and
    # the residual off the plane of the ball's and the felt's colours (about 0). A smear of another colour over the
    # felt (a red figure swung fast, for a yellow ball) passes pixel by pixel for a darker felt and a faint ball, a
    # few levels off the plane, but all of its pixels alike.
    felt_scale: float = 1.0
    bias: float = 0.0


def mixing(window: np.ndarray, ball: np.ndarray, felt: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32: per pixel the felt share a, the ball share alpha, and the residual off their plane."""
    f, b = np.asarray(felt, np.float64), np.asarray(ball, np.float64)
    basis = np.stack([f, b], axis=1)
    normal = np.cross(f, b)
    normal /= max(np.linalg.norm(normal), 1e-9)
    m = np.vstack([np.linalg.pinv(basis), normal]).astype(np.float32)
    return cv2.transform(window.astype(np.float32), m)


def smoothed(alpha: np.ndarray, known: np.ndarray, box: int) -> np.ndarray:
    """The shares averaged over a box of known pixels (0 elsewhere): noise, and a render's sub-frames that bead a long
    streak (its shares along the axis go up and down by half), smoothed out."""
    weight = known.astype(np.float32)
    total = cv2.boxFilter(alpha * weight, -1, (box, box), normalize=False)
    return np.where(known, total / np.maximum(cv2.boxFilter(weight, -1, (box, box), normalize=False), 1.0), 0.0)


def known_mask(mix: np.ndarray) -> np.ndarray:
    """bool: pixels whose colour says what they are, ball or felt (or a mix): the rest (a rod, a figure of another
    colour, a wall) may hide the ball and does not count."""
    a, alpha, residual = mix[..., 0], mix[..., 1], mix[..., 2]
    # |residual| <= RESIDUAL_MAX + 0.1 |alpha| 255, and the felt's scale a / max(1 - alpha, 1e-3) in FELT_SCALE or
    # alpha solid: the same operations in the same order, in place (a third less time on a window of a 1080p field).
    limit = np.abs(alpha)
    limit *= 0.1
    limit *= 255
    limit += RESIDUAL_MAX
    known = np.abs(residual) <= limit
    scale = np.subtract(1.0, alpha, dtype=np.float32)
    np.maximum(scale, 1e-3, out=scale)
    np.divide(a, scale, out=scale)
    felt = scale >= FELT_SCALE[0]
    felt &= scale <= FELT_SCALE[1]
    felt |= alpha >= SOLID_ALPHA
    known &= felt
    return known


def ball_coloured_figures(alpha: np.ndarray, mask: np.ndarray, axes: np.ndarray, radius: float,
                          pad: float = 0.0) -> Optional[np.ndarray]:
    """bool, or None where there is none: the pixels of mask that are solid ball colour, in pieces that come within
    FIGURE_REACH radii of a rod's axis (axes, nonzero on the axes' pixels), FIGURE_MARGIN radii (and pad px) around
    them included: figures of the ball's colour."""
    solid = (mask & (alpha >= SOLID_ALPHA)).astype(np.uint8)
    if not np.any(solid) or not np.any(axes):
        return None
    # Pixels to the nearest axis pixel (linear in the window, whatever the reach).
    to_axis = cv2.distanceTransform((axes == 0).astype(np.uint8), cv2.DIST_L2, 3)
    over_axis = (solid > 0) & (to_axis <= FIGURE_REACH * radius)
    if not np.any(over_axis):
        return None
    _, labels = cv2.connectedComponents(solid, connectivity=8)
    figures = np.isin(labels, np.unique(labels[over_axis])).astype(np.uint8)
    k = 2 * max(1, int(round(FIGURE_MARGIN * radius + pad))) + 1
    return cv2.dilate(figures, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))) > 0


def _streak_model(params: np.ndarray, s: np.ndarray, q: np.ndarray, radius: float, rest_end: float = 1.0) -> np.ndarray:
    """The share of the exposure each pixel (s along the axis, q across, from the first guess) saw a disc of this
    radius that went uniformly from c - m/2 to c + m/2 along the axis and rested at one end (rest_end, +1 or -1) for a
    share g of the exposure (a ball struck from rest, or stopped by a figure), times the ball's contrast k:
    params = [c, q offset e, m, k, g]."""
    c, e, m, k, g = params
    m = max(m, 0.25)
    half_chord = np.sqrt(np.maximum(radius * radius - (q - e) ** 2, 0.0))
    overlap = np.minimum(s + half_chord, c + m / 2) - np.maximum(s - half_chord, c - m / 2)
    moving = np.clip(overlap, 0.0, None) / m
    if g <= 0:
        return k * moving
    resting = np.clip(radius + 0.5 - np.hypot(s - c - rest_end * m / 2, q - e), 0.0, 1.0)  # edge pixels partly covered
    return k * ((1.0 - g) * moving + g * resting)


def _least_squares(residuals: Callable[[np.ndarray], np.ndarray], params: np.ndarray, steps: np.ndarray,
                   lower: np.ndarray, upper: np.ndarray, iterations: int) -> np.ndarray:
    """Levenberg-Marquardt with forward differences (steps) within bounds; stops once no parameter moves more than
    a twelfth of its difference step (0.02 px for the positions)."""
    damping = 1e-3
    residual = residuals(params)
    cost = float(np.dot(residual, residual))
    eye = np.eye(len(params))
    for _ in range(iterations):
        jac = np.stack([(residuals(params + eye[i] * steps[i]) - residual) / steps[i] for i in range(len(params))],
                       axis=1)
        a = jac.T @ jac
        g = jac.T @ residual
        while damping < 1e6:
            step = -np.linalg.solve(a + damping * np.diag(np.diag(a) + 1e-9), g)
            trial = np.clip(params + step, lower, upper)
            r_trial = residuals(trial)
            c_trial = float(np.dot(r_trial, r_trial))
            if c_trial < cost:
                params, residual, cost = trial, r_trial, c_trial
                damping = max(damping / 3, 1e-6)
                break
            damping *= 4
        else:
            break
        if np.all(np.abs(step) < steps / 12):
            break
    return params


def _explained(model: np.ndarray, observed: np.ndarray) -> float:
    """The share of the sum of the observed shares' squares that the model explains."""
    residual = model - observed
    return 1.0 - float(np.dot(residual, residual)) / max(float(np.dot(observed, observed)), 1e-9)


def fit_streak(alpha: np.ndarray, known: np.ndarray, centre: tuple[float, float], axis: np.ndarray, motion: float,
               radius: float, iterations: int = 12, start: Optional[np.ndarray] = None,
               rest_end: float = 1.0) -> tuple[np.ndarray, float]:
    """Least squares of the streak model to the ball shares of the known pixels (alpha, known: a window; centre in
    its pixels): (params [c, e, m, k, g], the share of the sum of the shares' squares that the model explains).
    Pixels hidden by something else do not count, so a rod across the streak or a figure over one end leaves the ends
    seen to place it. With one end hidden, a longer, fainter streak fits as well as the true one, or one that rested
    there: the contrast is held near CONTRAST and the rest near none (priors worth CONTRAST_WEIGHT of the pixels)."""
    ys, xs = np.nonzero(known)
    dx, dy = xs - centre[0], ys - centre[1]
    s = dx * axis[0] + dy * axis[1]
    q = -dx * axis[1] + dy * axis[0]
    near = np.abs(q) <= 1.5 * radius
    s, q, observed = s[near], q[near], np.clip(alpha[ys[near], xs[near]], -0.3, 1.3)
    prior = math.sqrt(CONTRAST_WEIGHT * len(observed))

    def residuals(p: np.ndarray) -> np.ndarray:
        return np.append(_streak_model(p, s, q, radius, rest_end) - observed, [prior * (p[3] - CONTRAST), prior * p[4]])

    params = np.array([0.0, 0.0, max(motion, 0.5), CONTRAST, 0.0]) if start is None else np.array(start, float)
    params = _least_squares(residuals, params, np.array([0.25, 0.25, 0.25, 0.01, 0.01]),
                            np.array([-np.inf, -np.inf, 0.0, -np.inf, 0.0]), np.array([np.inf, np.inf, np.inf, np.inf, 0.95]),
                            iterations)
    return params, _explained(_streak_model(params, s, q, radius, rest_end), observed)


def half_exposure_point(alpha: np.ndarray, known: np.ndarray, centre: tuple[float, float], axis: np.ndarray,
                        params: np.ndarray, radius: float, extent: tuple[float, float], rest_end: float = 1.0) -> float:
    """Where along the axis (from centre, pixels of alpha) half of the streak's shares lie on either side: the ball
    at mid-exposure, whatever its speed did during it (struck from rest, slowed by a hit), as long as it went one
    way. The shares that a rod or a figure hides, or that lie outside alpha, are the fitted model's. extent: the
    blob's own reach along the axis (from centre)."""
    s, _, mass = _completed_shares(alpha, known, centre, axis, params, radius, extent, rest_end)
    order = np.argsort(s, kind="stable")
    cumulative = np.cumsum(mass[order])
    if cumulative[-1] <= 0:
        return float(params[0])
    return float(s[order][min(int(np.searchsorted(cumulative, cumulative[-1] / 2)), len(order) - 1)])


def completed_spread(alpha: np.ndarray, known: np.ndarray, centre: tuple[float, float], axis: np.ndarray,
                     params: np.ndarray, radius: float, extent: tuple[float, float], rest_end: float = 1.0) -> float:
    """The spread of the streak's shares across its axis, over a disc's, with the shares that a rod or a figure hides
    (or that lie outside alpha) taken from the fitted model: for a streak that something hides along one side."""
    _, q, mass = _completed_shares(alpha, known, centre, axis, params, radius, extent, rest_end)
    mass = np.clip(mass, 0.0, None)
    total = float(mass.sum())
    if total <= 0:
        return 0.0
    mean = float(np.dot(mass, q)) / total
    return math.sqrt(max(float(np.dot(mass, (q - mean) ** 2)) / total, 0.0)) / (radius / 2)


def _completed_shares(alpha: np.ndarray, known: np.ndarray, centre: tuple[float, float], axis: np.ndarray,
                      params: np.ndarray, radius: float, extent: tuple[float, float],
                      rest_end: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(s along, q across, share) on a grid over the streak and half a radius beyond: the shares seen where the pixel
    is known, the fitted model's elsewhere."""
    c, e, m = params[:3]
    lo = min(extent[0], c - m / 2 - radius) - 0.5 * radius
    hi = max(extent[1], c + m / 2 + radius) + 0.5 * radius
    s, q = np.meshgrid(np.arange(math.floor(lo), math.ceil(hi) + 1, dtype=np.float64),
                       np.arange(math.floor(e - 1.2 * radius), math.ceil(e + 1.2 * radius) + 1, dtype=np.float64))
    s, q = s.ravel(), q.ravel()
    xs = np.round(centre[0] + s * axis[0] - q * axis[1]).astype(int)
    ys = np.round(centre[1] + s * axis[1] + q * axis[0]).astype(int)
    h, w = alpha.shape
    inside = (xs >= 0) & (xs < w) & (ys >= 0) & (ys < h)
    seen = np.zeros(len(s), bool)
    seen[inside] = known[ys[inside], xs[inside]]
    mass = _streak_model(params, s, q, radius, rest_end)
    mass[seen] = np.clip(alpha[ys[seen], xs[seen]], -0.3, 1.3)
    return s, q, mass


def _segment_window(centre: tuple[float, float], axis: np.ndarray, lo: float, hi: float, pad: float,
                    shape: tuple[int, int]) -> tuple[int, int, int, int]:
    """(x0, y0, x1, y1) of the pixels within pad of the segment from centre + lo * axis to centre + hi * axis."""
    ends = np.array([[centre[0] + t * axis[0], centre[1] + t * axis[1]] for t in (lo, hi)])
    x0, y0 = np.floor(ends.min(axis=0) - pad).astype(int)
    x1, y1 = np.ceil(ends.max(axis=0) + pad).astype(int) + 1
    return max(0, x0), max(0, y0), min(shape[1], x1), min(shape[0], y1)


@dataclass
class _Blob:
    """A blob's shares and their moments (window pixels): the first guess of a streak."""
    xs: np.ndarray
    ys: np.ndarray
    shares: np.ndarray
    centre: tuple[float, float]
    axis: np.ndarray
    motion: float
    spread: float  # across the axis, over a disc's
    radius: float
    disc_share: float  # the shares' sum over the disc's area
    felt_scale: float  # median over its pixels of the felt's brightness behind them (a / (1 - alpha)), over the median felt's
    bias: float  # median over its pixels of the residual off the plane of the ball's and the felt's colours (8-bit levels)
    cut: bool = False  # narrower than a disc, against something that may hide the ball along one side (_cut_along)


def _cut_along(xs: np.ndarray, ys: np.ndarray, centre: tuple[float, float], axis: np.ndarray, hidden: np.ndarray) -> bool:
    """Something that may hide the ball (hidden, bool) lies along one of the blob's long sides: CUT_SIDE or more of the
    pixels CUT_PROBE px beyond its edge on that side, one per pixel along the axis, are hidden. A rod across a streak
    hides a few of them on both sides; a figure lying over one side of it, most on that side."""
    s = np.round((xs - centre[0]) * axis[0] + (ys - centre[1]) * axis[1]).astype(int)
    q = -(xs - centre[0]) * axis[1] + (ys - centre[1]) * axis[0]
    h, w = hidden.shape
    for side in (-1.0, 1.0):
        edge = np.full(s.max() - s.min() + 1, -np.inf)
        np.maximum.at(edge, s - s.min(), side * q)
        steps = np.nonzero(np.isfinite(edge))[0]
        along, out = steps + s.min(), side * (edge[steps] + CUT_PROBE)
        px = np.round(centre[0] + along * axis[0] - out * axis[1]).astype(int)
        py = np.round(centre[1] + along * axis[1] + out * axis[0]).astype(int)
        inside = (px >= 0) & (px < w) & (py >= 0) & (py < h)
        if np.count_nonzero(hidden[py[inside], px[inside]]) >= CUT_SIDE * len(steps):
            return True
    return False


def _blobs(mix: np.ndarray, alpha: np.ndarray, mask: np.ndarray, grouping: np.ndarray,
           radius_at: Callable[[float, float], float], origin: tuple[int, int], limits: _Limits,
           hidden: np.ndarray, crowded: Optional[np.ndarray] = None) -> list[_Blob]:
    """The blobs of mask (grouped as in grouping) that may be streaks by their moments. hidden: the pixels that may
    hide the ball (a blob narrower than a disc against them along one side may be one still, CUT_WIDTH). crowded
    (bool, the window's shape), when given, is set on the pixels of the groups that are too much for a ball: too
    solid, too many discs of shares, or too wide (limits)."""
    n, labels, stats, _ = components_with_stats(grouping)
    x0, y0 = origin
    blobs = []
    for i in range(1, n):
        bx, by, bw, bh, area = stats[i]
        radius = radius_at(bx + bw / 2 + x0, by + bh / 2 + y0)
        if area < limits.shares[0] * math.pi * radius * radius:
            continue  # too few pixels for the shares of a disc, even all ball
        # The group, and the pixels of mask next to it (a streak's own pixels beside what hides part of it).
        right, bottom = min(bx + bw + 1, labels.shape[1]), min(by + bh + 1, labels.shape[0])
        bx, by = max(bx - 1, 0), max(by - 1, 0)
        bw, bh = right - bx, bottom - by
        group = cv2.dilate((labels[by:by + bh, bx:bx + bw] == i).astype(np.uint8), np.ones((3, 3), np.uint8))
        ys, xs = np.nonzero((group > 0) & (mask[by:by + bh, bx:bx + bw] > 0))
        shares = np.clip(alpha[by:by + bh, bx:bx + bw][ys, xs], 0.0, 1.0)
        total = float(shares.sum())
        xs, ys = xs + bx, ys + by
        if total <= 0:
            continue
        if shares.max() >= limits.peak or np.count_nonzero(shares >= SOLID_ALPHA) > limits.solid * len(shares):
            if crowded is not None:
                crowded[ys, xs] = True
            if not limits.solid_judged:
                continue
        # np.dot, not @: a vector product of mixed types (int64 or float64 by float32) in @ takes numpy's generic
        # loop, 25 times slower (20 ms a call of find_streaks on goal5's windows).
        cu, cv_ = float(np.dot(xs, shares) / total), float(np.dot(ys, shares) / total)
        radius = radius_at(cu + x0, cv_ + y0)
        disc = math.pi * radius * radius
        if crowded is not None and total > limits.crowd_shares * disc:
            crowded[ys, xs] = True
        if not limits.shares[0] * disc <= total <= limits.shares[1] * disc:
            continue
        dx, dy = xs - cu, ys - cv_
        cov = np.array([[np.dot(shares, dx * dx), np.dot(shares, dx * dy)],
                        [np.dot(shares, dx * dy), np.dot(shares, dy * dy)]]) / total
        values, vectors = np.linalg.eigh(cov)
        across, along = max(values[0], 1e-6), max(values[1], 1e-6)
        motion = math.sqrt(max(0.0, 12.0 * (along - across)))
        spread = math.sqrt(across) / (radius / 2)
        if spread > limits.crowd_width and crowded is not None:
            crowded[ys, xs] = True
        if motion < limits.min_motion * radius or spread > limits.width[1]:
            continue
        cut = (spread < limits.width[0] and spread >= CUT_WIDTH
               and _cut_along(xs, ys, (cu, cv_), vectors[:, 1], hidden))
        if (spread >= limits.width[0] or cut) and limits.first:  # only whether there is one: no medians taken
            return [_Blob(xs, ys, shares, (cu, cv_), vectors[:, 1], motion, spread, radius, total / disc, 1.0, 0.0)]
        if spread >= limits.width[0] or cut:
            felt, share, residual = mix[ys, xs, 0], mix[ys, xs, 1], mix[ys, xs, 2]
            blobs.append(_Blob(xs, ys, shares, (cu, cv_), vectors[:, 1], motion, spread, radius, total / disc,
                               float(np.median(felt / np.maximum(1.0 - share, 1e-3))), float(np.median(residual)), cut))
    return blobs


def _fit_from(start: np.ndarray, rest_end: float, blob: _Blob, alpha: np.ndarray, known: np.ndarray,
              reach: tuple[float, float]) -> tuple[np.ndarray, float]:
    """The fit from a first guess, on the known pixels two radii around the blob's reach along its axis; again further
    out when the streak it finds goes on under something (a figure over one end, the rest of it beyond)."""
    (cu, cv_), axis, radius = blob.centre, blob.axis, blob.radius
    lo, hi = reach
    params, explained = start, 0.0
    for _ in range(2):
        wx0, wy0, wx1, wy1 = _segment_window((cu, cv_), axis, lo, hi, 2 * radius + 2, alpha.shape)
        params, explained = fit_streak(alpha[wy0:wy1, wx0:wx1], known[wy0:wy1, wx0:wx1], (cu - wx0, cv_ - wy0),
                                       axis, params[2], radius, start=params, rest_end=rest_end)
        c, m = params[0], params[2]
        if c - m / 2 - radius >= lo - 0.5 * radius and c + m / 2 + radius <= hi + 0.5 * radius:
            break
        lo, hi = min(lo, c - m / 2 - radius), max(hi, c + m / 2 + radius)
    return params, explained


def _measure(blob: _Blob, alpha: np.ndarray, known: np.ndarray, origin: tuple[int, int]) -> Streak:
    """The blob as a streak: the ball at mid-exposure, by the fitted model that explains the shares best."""
    (cu, cv_), axis, radius = blob.centre, blob.axis, blob.radius
    extent = (blob.xs - cu) * axis[0] + (blob.ys - cv_) * axis[1]  # from the centroid
    lo, hi = float(extent.min()), float(extent.max())
    # First guess: the moments' streak, moving all the exposure, resting (if at all) at the end its shares crowd to.
    guesses = [(np.array([0.0, 0.0, blob.motion, CONTRAST, 0.0]), 1.0 if (lo + hi) / 2 <= 0.0 else -1.0)]
    peak = int(np.argmax(blob.shares))
    if blob.shares[peak] >= REST_PEAK * float(np.median(blob.shares)):
        # A bright disc in a faint streak: the ball rested there (struck from rest, or stopped by a figure) and went
        # to the blob's other end. From the moments' guess the fit does not find that: it must move the whole streak.
        rest_end = 1.0 if extent[peak] >= (lo + hi) / 2 else -1.0
        far = lo + radius if rest_end > 0 else hi - radius
        guesses.append((np.array([(extent[peak] + far) / 2, 0.0, abs(extent[peak] - far), CONTRAST, 0.25]), rest_end))
    fits = [(_fit_from(start, rest_end, blob, alpha, known, (lo, hi)), rest_end) for start, rest_end in guesses]
    (params, explained), rest_end = max(fits, key=lambda fit: fit[0][1])
    c = half_exposure_point(alpha, known, (cu, cv_), axis, params, radius, (lo, hi), rest_end)
    # A blob that something hides along one side is as wide as the fitted streak makes it, the hidden shares its.
    spread = completed_spread(alpha, known, (cu, cv_), axis, params, radius, (lo, hi), rest_end) if blob.cut else blob.spread
    x0, y0 = origin
    u, v = cu + c * axis[0] - params[1] * axis[1], cv_ + c * axis[1] + params[1] * axis[0]
    return Streak(u + x0, v + y0, blob.disc_share, axis, float(params[2]), spread, float(blob.shares.max()),
                  len(blob.xs), float(params[3]), explained, cu + x0, cv_ + y0, radius, float(params[4]),
                  blob.felt_scale, blob.bias)


def _grouping(mask: np.ndarray, plain: np.ndarray, alpha: np.ndarray, k: int) -> np.ndarray:
    """uint8: mask, its gaps up to k px closed where something may hide the ball (not plain: a rod across a streak) or
    the ball's share is faint but there (a long streak's beads), not across bare felt."""
    closed = cv2.morphologyEx(mask, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
    return mask | (closed & (~plain | (alpha >= ALPHA_MIN / 2))).astype(np.uint8)


def find_streaks(bgr: np.ndarray, roi: tuple[int, int, int, int], radius_at: Callable[[float, float], float],
                 ball_bgr: np.ndarray, felt_bgr: np.ndarray, region: Optional[np.ndarray] = None,
                 bridge: float = 1.6, min_motion: float = 1.0, width: tuple[float, float] = (0.7, 1.3),
                 near: Optional[tuple[float, float]] = None, most: int = 3,
                 rod_axes: Optional[np.ndarray] = None) -> list[Streak]:
    """Blobs of mixed ball and felt pixels in roi = (x0, y0, x1, y1), measured as streaks. bridge: gaps up to this
    many radii are grouped into one blob where something may hide the ball (a rod across the streak) or its share is
    faint but there, not across bare felt (_grouping). Only blobs whose second moments say that they
    moved min_motion radii or more and whose spread across their axis is `width` times a disc's (a rod's highlight is
    thinner) are measured, at most `most` of them, the nearest to `near` (a full-frame pixel) first: a fit costs
    5-10 ms. rod_axes: the image of the rods' axes (nonzero on them; BallSearch gives it for a coloured ball): solid
    ball colour by one is a figure, hidden (ball_coloured_figures). A ball of COARSE_RADIUS px or more is looked for
    at half resolution first (may_hold_streak): where nothing there may be a streak, the full resolution is spared."""
    x0, y0, x1, y1 = roi
    radius = radius_at((x0 + x1) / 2, (y0 + y1) / 2)
    if radius >= COARSE_RADIUS and not may_hold_streak(bgr, roi, radius, radius_at, ball_bgr, felt_bgr, region,
                                                       bridge, min_motion, width, rod_axes):
        return []
    window = (slice(y0, y1), slice(x0, x1))
    mix, known, blobs = _window_blobs(bgr[window], (x0, y0), radius, radius_at, ball_bgr, felt_bgr,
                                      None if region is None else region[window], bridge,
                                      _Limits.exact(min_motion, width), None if rod_axes is None else rod_axes[window])
    if near is not None:
        blobs.sort(key=lambda b: math.hypot(b.centre[0] + x0 - near[0], b.centre[1] + y0 - near[1]))
    if blobs:
        alpha = smoothed(mix[..., 1], known, max(3, int(round(SMOOTHING * radius)) | 1))
    return [_measure(blob, alpha, known, (x0, y0)) for blob in blobs[:most]]


def may_hold_streak(bgr: np.ndarray, roi: tuple[int, int, int, int], radius: float,
                    radius_at: Callable[[float, float], float], ball_bgr: np.ndarray, felt_bgr: np.ndarray,
                    region: Optional[np.ndarray] = None, bridge: float = 1.6, min_motion: float = 1.0,
                    width: tuple[float, float] = (0.7, 1.3), rod_axes: Optional[np.ndarray] = None) -> bool:
    """Something in roi may be a streak (find_streaks' arguments; radius: the ball's at the roi's centre): a blob of
    the window at half resolution (2x2 pixels averaged) passes the loosened limits (_Limits.coarse). The region and
    the rods' axes count where any of a half-resolution pixel's 4 pixels does."""
    x0, y0, x1, y1 = roi
    w, h = (x1 - x0) // 2, (y1 - y0) // 2
    if w < 3 or h < 3:
        return True
    x1, y1 = x0 + 2 * w, y0 + 2 * h  # an even window: each pixel at half resolution is the mean of 2x2

    def half(image: np.ndarray) -> np.ndarray:
        return cv2.resize(image[y0:y1, x0:x1], (w, h), interpolation=cv2.INTER_AREA)

    def radius_at_half(u: float, v: float) -> float:
        return radius_at(x0 + 2 * u + 0.5, y0 + 2 * v + 0.5) / 2

    _, _, blobs = _window_blobs(half(bgr), (0, 0), radius / 2, radius_at_half, ball_bgr, felt_bgr,
                                None if region is None else half(region), bridge, _Limits.coarse(min_motion, width),
                                None if rod_axes is None else half(rod_axes))
    return bool(blobs)


def _window_blobs(window: np.ndarray, origin: tuple[int, int], radius: float,
                  radius_at: Callable[[float, float], float], ball_bgr: np.ndarray, felt_bgr: np.ndarray,
                  region: Optional[np.ndarray], bridge: float, limits: _Limits,
                  rod_axes: Optional[np.ndarray]) -> tuple[np.ndarray, np.ndarray, list[_Blob]]:
    """(the window's mixing, its known pixels, the blobs that limits keep) of a BGR window whose pixel (0, 0) is
    `origin` for radius_at; region and rod_axes: the window's own (nonzero: the field, an axis)."""
    x0, y0 = origin
    mix = mixing(window, ball_bgr, felt_bgr)
    plain = known_mask(mix)
    if region is not None:
        plain &= region > 0
    # A streak many radii long is a few times the noise: its pixels are found on shares averaged over 3x3.
    alpha = smoothed(mix[..., 1], plain, 3)
    seen = (plain & (alpha >= ALPHA_MIN)).astype(np.uint8)
    # An occluder's edge pixels blend it with the felt, and a grey rod's or a red figure's blend can pass for a share
    # of the ball: for the fit, the pixels next to anything unknown are not known either.
    clear = cv2.erode(plain.astype(np.uint8), np.ones((3, 3), np.uint8), borderType=cv2.BORDER_REPLICATE) > 0
    k = max(1, int(round(bridge * radius)))
    blobs: list[_Blob] = []
    for figure_pad in limits.figure_pads:
        mask, known = (seen, clear) if len(limits.figure_pads) == 1 else (seen.copy(), clear.copy())
        figures = None
        if rod_axes is not None:
            figures = ball_coloured_figures(alpha, mask > 0, rod_axes, radius, figure_pad)
            if figures is not None:
                mask[figures] = 0
                known &= ~figures
        blobs = _grouped_blobs(mix, plain, alpha, mask, known, k, radius_at, origin, limits)
        if blobs or figures is None:
            break  # (without figures, another margin around them changes nothing)
    return mix, known, blobs


def _grouped_blobs(mix: np.ndarray, plain: np.ndarray, alpha: np.ndarray, mask: np.ndarray, known: np.ndarray, k: int,
                   radius_at: Callable[[float, float], float], origin: tuple[int, int], limits: _Limits) -> list[_Blob]:
    """The blobs of mask that limits keep, grouped across gaps of k px (_grouping), and those too much for a ball
    grouped again by their clear pixels."""
    x0, y0 = origin
    crowded = np.zeros(mask.shape, bool)
    blobs = _blobs(mix, alpha, mask, _grouping(mask, plain, alpha, k), radius_at, (x0, y0), limits, ~known, crowded)
    # A streak that touches the blend of something hidden with the felt (a figure's outline) is one blob with it, too
    # wide or too solid: such blobs are grouped again by their pixels clear of anything hidden (a streak's own pixels
    # next to one join the blob they touch), and what of them is a streak by its moments is measured too.
    if np.any(crowded) and not (blobs and limits.first):
        # Only around the crowded pixels: the closing of the clear ones is nothing further than its kernel from them,
        # so a box that wide around them (and a few pixels for the blobs' own margins) finds the same blobs.
        cx, cy, cw, ch = cv2.boundingRect(crowded.astype(np.uint8))
        pad = k + 2 + 4
        bx0, by0 = max(0, cx - pad), max(0, cy - pad)
        bx1, by1 = min(mask.shape[1], cx + cw + pad), min(mask.shape[0], cy + ch + pad)
        box = (slice(by0, by1), slice(bx0, bx1))
        clear = (mask[box] & known[box] & crowded[box]).astype(np.uint8)
        for blob in _blobs(mix[box], alpha[box], mask[box] & crowded[box], _grouping(clear, known[box], alpha[box], k + 2),
                           radius_at, (x0 + bx0, y0 + by0), limits, ~known[box]):
            blob.xs, blob.ys, blob.centre = blob.xs + bx0, blob.ys + by0, (blob.centre[0] + bx0, blob.centre[1] + by0)
            blobs.append(blob)
    return blobs
