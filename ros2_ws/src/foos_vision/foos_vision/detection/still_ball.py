"""The ball in one frame, with nothing else known: no tags, no corners, no colour, no frames before it.

What a ball is, in one picture of a table: the playing field is the largest stretch of one colour in the middle of
the image (the felt) that the rods cross (a zoomed-out frame's crowd and floor can be the middle's commonest colour;
no rods cross them, so the next commonest colour is tried); the ball lies on it, is as wide as the table's ball is
in the felt's own scale (field_size / ball diameter), and is lighter than the felt (every ball colour in play,
white, yellow, yellow-green, orange and cork, is lighter than green, blue or black felt, while the figures' heads and
the shadows are darker or the same).

Candidates are the peaks of a disc-minus-ring filter on how much lighter than the felt around it each pixel is,
at the ball's predicted radius (a disc as wide as the ball and lighter than its surroundings answers most; a line, a
rod's highlight or a lit wall is as light in the ring as in the disc, and a dark neighbour does not help, since only
light above the felt counts). Each is scored on what only a ball has all of:
- its shape: the correlation of its light with a disc of the ball's size in a ring of felt (a line, a streak or a
  lit edge correlates poorly);
- its rim: the edges around it (the light falling outward) lie on one circle of about the ball's radius, with the
  light inside, all around it: the share of 16 sectors of that circle where such an edge is found. A streak, a line, a
  rod's highlight beside a figure or a lit wall have straight edges, which meet a circle of the ball's size in a few
  sectors only. The circle's centre is the ball's reported centre: the light's peak lies on the ball's lit top;
- its colour is its own: figures wear a team's colour, one colour on a dozen bodies across the field, while the
  ball is one ball's area of its colour. A candidate whose (chromatic) colour covers several balls' worth of the
  field is a figure.
Before the filter, the light on the rods is taken out. A lamp's reflection on a steel rod, cut off by a figure on the
rod, is as wide, light and round as a ball, but it lies on the rod's axis, where a ball (even one touching the rod)
does not. The rods are found as a family: the straight lines that cross the felt with an edge along most of the way
(the rods' edges and their sheen, whole lines found by a Hough transform, not segments), in the direction most of
them share (the rods are parallel; perspective turns them a few degrees). The light on those lines, one pixel wide
each, is set to none; a painted line parallel to the rods goes too, which is no ball either.
A ball in a figure's shade shows little light: a thin lit cap over a body 10-30 light levels above the felt, which the
light's disc filter sees as an arc, not a disc. A second cue, its tint, sees the whole of it: how far a pixel's
chroma lies from what white light makes of the felt around it (the segment from the felt's chroma to grey's, on which
the felt's painted lines, the rods' sheen and white socks all lie, however light), where the pixel is lighter than the
felt and not in a team's colour. No ball colour is named: any ball but a white or grey one lies off that segment, and
a white one is lit enough for the light cue. Past the felt, away from grey, the segment reaches as far as the pixel is
lighter than the felt: a lamp's stronger light on a coloured cloth raises its chroma too. The tint's candidates are
found and scored as the light's are (on the felt found only: past it lie the walls, whose colour is a tint of its own).
The best light candidate is the ball when its score reaches MIN_SCORE and it leads every other light candidate more
than a ball's width away by MIN_LEAD: two things in a frame that look as much like a ball as each other make the pick a
guess, and a wrong ball costs more than none (the frame then has no ball to report). Only when the light has no clear
ball may a tint candidate be it, leading every candidate of both cues by MIN_LEAD and reaching MIN_TINT_SCORE.

A learned check may join the rules (StillBallFinder(verifier=...), detection.ball_verifier: a small net trained on the
simulated camera's renders that scores the patch around each candidate); it is off by default, because on real frames
it lost more balls than it found (docs/measurements/vision-2026-11-28-verifier-5.md).

StillBallFinder.find(bgr) returns the field it found (a convex outline and the ball's radius in pixels there) and
the ball candidates, best first; ball(bgr) the one it would report. The real-footage bench (real_bench) scores it
on single frames with labels; the tracker does not use it (a video has motion and the tags' mapping, see
motion_ball).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from foos_core.table_geometry import TableGeometry

from .ball_verifier import BallVerifier

WORK_WIDTH = 1280  # px: frames are searched at this width (a 1080p ball of 16-40 px keeps 11-27 px)
FELT_CHROMA_TOL = 6.0  # Lab a/b levels around the felt's mode that are still felt
FELT_LIGHT_TOL = 45.0  # L levels: the felt's light falls off toward the walls
MIN_FELT_FILL = 0.5  # of the felt's closed stretch that is felt-coloured
MIN_FIELD_SHARE = 0.08  # of the image: less, and the felt found is not a table's playing field
FELT_TRIES = 3  # the middle's commonest colours tried as the felt, commonest first
MIN_ROD_LINES = 4  # rods' lines (_rod_family) a table's felt is crossed by, at least: half of its 8 rods, as a frame
# that shows part of the field has them (the felt of the real stills and renders: 24-58 lines; 225's grey clothing: 0)
FIELD_MARGIN = 2.0  # ball radii: the ball is searched this far past the felt found (its lit or shaded ends and walls)
SCALES = (0.75, 0.9)  # of the predicted radius: the lit part of a ball (its shaded underside is the felt's light)
RING = (1.3, 1.9)  # radii of the ring of surroundings, in disc radii
MIN_PEAK = 6.0  # L levels: the disc's light above the ring's, at least
MAX_PEAKS = 60  # the strongest peaks scored per frame
RIM_SECTORS = 16  # sectors of the circle the rim is looked for in
RIM_RADII = (0.7, 0.85, 1.0, 1.15)  # of the predicted radius: the lit part of a ball, and perspective's +-15 %
RIM_TOL = 0.25  # of the circle's radius (at least RIM_TOL_PX): an edge this near the circle lies on it
RIM_TOL_PX = 1.5  # work pixels
RIM_ANGLE = 30.0  # degrees: an edge on the rim faces the centre (the light rises toward it) within this
RIM_SHIFT = 0.6  # of the predicted radius: the circle's centre is searched this far from the light's peak
MIN_EDGE = 4.0  # L levels per px: an edge (Sobel of the lightly smoothed L, per px)
CHROMATIC = 20.0  # Lab a/b levels from grey: a colour (a team's), not white, grey or black
TEAM_TOL = 8  # Lab a/b levels: the same colour
TEAM_BALLS = 4.0  # a colour covering this many balls' areas of the field is half way to a team's (score halved)
ROD_SPAN = 0.5  # of the felt's short side: a rod's line crosses at least this much of the felt (the field's width)
ROD_COVER = 0.5  # of its way across the felt with an edge on the line: figures on the rod hide the rest
ROD_TURN = 10.0  # degrees from the rods' common direction: perspective turns parallel rods this much at most
ROD_ANGLE_STEP = 0.5  # degrees: the Hough transform's angle resolution (at most 4 px off over a 500 px rod)
TINT_GAIN = 3.0  # light levels per chroma level: the felt's light varies about 3x as much as its chroma (15-24 vs 7-8)
MIN_SCORE = 0.6  # below this the best candidate is not reported: nothing in the frame is clearly a ball
MIN_TINT_SCORE = 0.7  # the same for a candidate found by its tint: more things on a table are tinted than lit
VETO_BELOW = 0.5  # the verifier's chance below which a hand-made pick is not reported
MIN_VERIFIED = 0.9  # the verifier's chance a candidate needs to be the ball where the hand-made rules pick none
MIN_VERIFIED_LEAD = 0.3  # over the verifier's next surest candidate more than a ball's width away
MIN_LEAD = 0.1  # the best's score over the next best's more than a ball's width away: less, and the pick is a guess


@dataclass
class FeltField:
    outline: np.ndarray  # (N, 2) convex outline of the felt, full-frame pixels
    felt_lab: tuple[float, float, float]  # the felt's colour, OpenCV 8-bit Lab
    ball_radius_px: float  # the ball's radius at the field's middle, full-frame pixels
    share: float  # the felt's share of the image


@dataclass
class StillCandidate:
    u: float
    v: float
    radius: float  # px, the disc's radius that answered best, full frame
    contrast: float  # L levels: the disc's light above the felt, minus the ring's
    shape: float  # correlation of the light with a disc in a ring, -1..1
    rim: float  # share of the sectors of a circle of the ball's size with an edge on it, light inside, 0..1
    team_balls: float  # balls' areas of the field in this candidate's colour (0: not a chromatic colour)
    score: float
    cue: str = "light"  # the map it was found in: "light" (lighter than the felt) or "tint" (its chroma, see _tinted)
    verified: Optional[float] = None  # the ball verifier's chance that this is the ball (None: not run)


class StillBallFinder:
    """verifier: a BallVerifier that scores every candidate (StillCandidate.verified), and whose score then picks the
    ball (_verified_pick) instead of the hand-made rules alone (_pick)."""

    def __init__(self, params_file: Optional[str] = None, verifier: Optional[BallVerifier] = None):
        self.table = TableGeometry.of(params_file)
        self.verifier = verifier

    def find_field(self, bgr: np.ndarray) -> Optional[FeltField]:
        """The felt: the commonest colour of the image's middle whose largest connected stretch the rods cross."""
        scale = WORK_WIDTH / bgr.shape[1]
        small = cv2.resize(bgr, (WORK_WIDTH, round(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
        lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
        return self._felt(lab, scale)[0]

    def _felt(self, lab: np.ndarray, scale: float) -> tuple[Optional[FeltField], Optional[np.ndarray]]:
        field, region, _ = self._felt_and_rods(lab, scale)
        return field, region

    def _felt_and_rods(self, lab: np.ndarray,
                       scale: float) -> tuple[Optional[FeltField], Optional[np.ndarray], list[tuple[float, float]]]:
        """The first of the middle's commonest colours (FELT_TRIES at most) whose stretch is a table's felt: large
        enough, mostly of its colour, and crossed by the rods (MIN_ROD_LINES of them). A crowd's grey clothes and the
        floor can be the commonest colour of the middle where the camera zooms out; they are crossed by no rods."""
        h, w = lab.shape[:2]
        # The table is in the middle of the picture, and the felt is most of the table.
        middle = lab[h // 3:2 * h // 3, w // 3:2 * w // 3].reshape(-1, 3).astype(np.float32)
        for a0, b0 in _commonest_chromas(middle, FELT_TRIES):
            field, region = self._felt_of(lab, scale, middle, a0, b0)
            if field is None:
                continue
            rods = _rod_family(lab, region)
            if len(rods) >= MIN_ROD_LINES:
                return field, region, rods
        return None, None, []

    def _felt_of(self, lab: np.ndarray, scale: float, middle: np.ndarray, a0: float,
                 b0: float) -> tuple[Optional[FeltField], Optional[np.ndarray]]:
        """The largest connected stretch of the colour near chroma (a0, b0) (refined on the middle's pixels near it),
        or None where it is too small or not mostly of that colour."""
        h, w = lab.shape[:2]
        chroma_near = ((np.abs(middle[:, 1] - a0) <= 1.5 * FELT_CHROMA_TOL)
                       & (np.abs(middle[:, 2] - b0) <= 1.5 * FELT_CHROMA_TOL))
        l0, a0, b0 = (float(x) for x in np.median(middle[chroma_near], axis=0))
        near = ((np.abs(middle[:, 1] - a0) <= FELT_CHROMA_TOL) & (np.abs(middle[:, 2] - b0) <= FELT_CHROMA_TOL)
                & (np.abs(middle[:, 0] - l0) <= FELT_LIGHT_TOL))
        if np.count_nonzero(near) >= 0.2 * len(middle):
            l0, a0, b0 = (float(x) for x in np.median(middle[near], axis=0))
        felt = ((np.abs(lab[..., 1].astype(np.int16) - a0) <= FELT_CHROMA_TOL)
                & (np.abs(lab[..., 2].astype(np.int16) - b0) <= FELT_CHROMA_TOL)
                & (np.abs(lab[..., 0].astype(np.int16) - l0) <= FELT_LIGHT_TOL)).astype(np.uint8)
        # Lines, rods and figures cut the felt into pieces: close over them before taking the largest piece.
        k = max(3, int(0.02 * w) | 1)
        closed = cv2.morphologyEx(felt, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k)))
        n, labels, stats, _ = cv2.connectedComponentsWithStats(closed, connectivity=8)
        if n < 2:
            return None, None
        best = 1 + int(np.argmax(stats[1:, cv2.CC_STAT_AREA]))
        share = stats[best, cv2.CC_STAT_AREA] / float(h * w)
        piece = labels == best
        # A felt is mostly of its colour before the closing (lines, rods and figures cover a part); noise is not.
        if share < MIN_FIELD_SHARE or np.count_nonzero(felt[piece]) < MIN_FELT_FILL * np.count_nonzero(piece):
            return None, None
        points = cv2.findNonZero(piece.astype(np.uint8))
        hull = cv2.convexHull(points).reshape(-1, 2)
        (_, _), (rw, rh), _ = cv2.minAreaRect(hull)
        short_side = min(rw, rh)
        # The felt's short side is the field's width: the ball is 2r / width of it.
        radius = self.table.ball_radius / (2 * self.table.half_width) * short_side
        region = np.zeros((h, w), np.uint8)
        cv2.fillConvexPoly(region, hull.astype(np.int32), 1)
        field = FeltField(hull.astype(float) / scale, (l0, a0, b0), radius / scale, share)
        return field, region

    def ball(self, bgr: np.ndarray) -> tuple[Optional[FeltField], Optional[StillCandidate]]:
        """The field and the candidate reported as the ball (None when there is no clear one, see _pick)."""
        field, candidates = self.find(bgr)
        return field, (_pick(candidates, field) if self.verifier is None else _verified_pick(candidates, field))

    def find(self, bgr: np.ndarray) -> tuple[Optional[FeltField], list[StillCandidate]]:
        """The field and the ball candidates in it, best first (empty when no felt is found)."""
        scale = WORK_WIDTH / bgr.shape[1]
        small = cv2.resize(bgr, (WORK_WIDTH, round(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
        lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
        field, region, rod_family = self._felt_and_rods(lab, scale)
        if field is None:
            return None, []
        r = field.ball_radius_px * scale
        lighter, around = _lighter_than_felt(small, lab, r)
        rods = _rod_lines(lab, region, rod_family) > 0
        lighter[rods] = 0.0
        team = _team_colours(lab, region, field.felt_lab, r)
        tinted = _tinted(lab, around, lighter, team)
        tinted[rods] = 0.0
        # The felt's colour changes where a lamp lights or a wall shades its ends: the felt found can stop short of
        # the field's edge by a ball's width, and a ball there is still on the field. The tint is measured against
        # the felt, so it is searched on the felt found only: past it lie the walls, whose own colour is a tint.
        grow = int(2 * FIELD_MARGIN * r) | 1
        searched = cv2.dilate(region, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (grow, grow))) > 0
        light = cv2.GaussianBlur(lab[..., 0].astype(np.float32), (0, 0), 1.0)
        found = (_candidates("light", lighter, light, lab, team, searched, r, scale)
                 + _candidates("tint", tinted, cv2.GaussianBlur(tinted, (0, 0), 1.0), lab, team, region > 0, r, scale))
        found.sort(key=lambda c: -c.score)
        if self.verifier is not None:
            verify(self.verifier, bgr, field, found)
        return field, found


def verify(verifier: BallVerifier, bgr: np.ndarray, field: FeltField, candidates: list[StillCandidate]) -> None:
    """Set each candidate's `verified` (in place): the verifier's chance that it is the ball, its patch scaled by the
    field's ball radius. The benches call it on candidates found without a verifier, to pick both ways from them."""
    chances = verifier.score(bgr, [(c.u, c.v) for c in candidates], field.ball_radius_px)
    for c, chance in zip(candidates, chances):
        c.verified = float(chance)


def _candidates(cue: str, strength: np.ndarray, edges_of: np.ndarray, lab: np.ndarray, team: np.ndarray,
                searched: np.ndarray, r: float, scale: float) -> list[StillCandidate]:
    """The peaks of the disc filter on a cue's map (strength: how much a pixel differs from the felt that way), each
    scored on its shape in that map, its rim in edges_of's edges and its team colour (full-frame pixels)."""
    contrast, radius = _disc_filter(strength, r)
    size = max(3, int(r) | 1)
    peaks = ((contrast == cv2.dilate(contrast, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size))))
             & (contrast >= MIN_PEAK) & searched)
    ys, xs = np.nonzero(peaks)
    order = np.argsort(-contrast[ys, xs])[:MAX_PEAKS]
    gx = cv2.Sobel(edges_of, cv2.CV_32F, 1, 0, ksize=3) / 8
    gy = cv2.Sobel(edges_of, cv2.CV_32F, 0, 1, ksize=3) / 8
    found = []
    for x, y in zip(xs[order], ys[order]):
        rr = float(radius[y, x])
        shape = _disc_correlation(strength, x, y, rr)
        if shape is None:
            continue
        rim, (cx, cy) = _rim(gx, gy, x, y, r)
        team_balls = _team_balls(lab, team, x, y, rr)
        score = shape * rim / (1.0 + (team_balls / TEAM_BALLS) ** 2)
        found.append(StillCandidate(cx / scale, cy / scale, rr / scale, float(contrast[y, x]), shape, rim,
                                    team_balls, score, cue))
    return found


def _commonest_chromas(middle: np.ndarray, tries: int) -> list[tuple[float, float]]:
    """The centres of the `tries` commonest chromas (a, b) of the pixels, in bins of FELT_CHROMA_TOL, each at least
    3 bins from the ones before it. Not the median: where the centre circle, its line and a logo fill the middle (an
    overhead camera), the median is a mix of felt and white that is neither."""
    bins = (middle[:, 1:] // FELT_CHROMA_TOL).astype(int)
    side = 256 // int(FELT_CHROMA_TOL) + 1
    counts = np.bincount(bins[:, 0] * side + bins[:, 1], minlength=side * side).reshape(side, side)
    counts = cv2.boxFilter(counts.astype(np.float32), -1, (3, 3), normalize=False, borderType=cv2.BORDER_CONSTANT)
    peaks = []
    for _ in range(tries):
        ka, kb = np.unravel_index(int(np.argmax(counts)), counts.shape)
        if counts[ka, kb] <= 0:
            break
        peaks.append(((ka + 0.5) * FELT_CHROMA_TOL, (kb + 0.5) * FELT_CHROMA_TOL))
        counts[max(0, ka - 2):ka + 3, max(0, kb - 2):kb + 3] = 0.0
    return peaks


def _lighter_than_felt(small: np.ndarray, lab: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """How much lighter than the felt around it each pixel is (L levels, 0 where darker: a dark figure next to a
    light spot must not make it look like a ball), and the felt around each pixel (Lab, float)."""
    light = lab[..., 0].astype(np.float32)
    # The felt's light around each pixel: a median over a few ball widths takes no ball and no line.
    k = min(255, max(5, int(6 * r) | 1))
    step = max(1, int(r // 2))
    coarse = cv2.medianBlur(small[::step, ::step] if step > 1 else small, min(k // step | 1, 255))
    around = cv2.resize(cv2.cvtColor(coarse, cv2.COLOR_BGR2Lab), (light.shape[1], light.shape[0]),
                        interpolation=cv2.INTER_LINEAR).astype(np.float32)
    return np.clip(light - around[..., 0], 0.0, None), around


def _tinted(lab: np.ndarray, around: np.ndarray, lighter: np.ndarray, team: np.ndarray) -> np.ndarray:
    """How far each pixel's chroma lies from what white light makes of the felt around it, in light levels
    (TINT_GAIN per Lab a/b level). White light on the felt, on its painted lines, on the rods' sheen and on white
    socks mixes the felt's chroma with grey's (128, 128): such pixels lie on the segment between the two and have no
    tint, whatever their light. A ball of any colour but white or grey lies off it, in shade as well as lit, where its
    light above the felt is a thin lit cap. Only where the pixel is lighter than the felt (fully from MIN_PEAK up: a
    figure's shadow and a dark figure are no ball, and a dark pixel's chroma is noise), and not in a team's colour."""
    a, b = lab[..., 1].astype(np.float32), lab[..., 2].astype(np.float32)
    felt_a, felt_b = around[..., 1], around[..., 2]
    to_grey_a, to_grey_b = 128.0 - felt_a, 128.0 - felt_b
    # A lamp lights the felt unevenly, and more light on a coloured cloth raises its chroma with its lightness (a lit
    # stripe of a saturated green felt is a stronger green, not a tint): past the felt, away from grey, the segment
    # reaches the felt's chroma scaled by the pixel's light over the felt's around it.
    brighter = np.maximum(lab[..., 0].astype(np.float32) / np.maximum(around[..., 0], 1.0) - 1.0, 0.0)
    along = np.clip(((a - felt_a) * to_grey_a + (b - felt_b) * to_grey_b)
                    / (to_grey_a ** 2 + to_grey_b ** 2 + 1e-6), -brighter, 1.0)
    off_axis = np.hypot(a - felt_a - along * to_grey_a, b - felt_b - along * to_grey_b)
    tint = TINT_GAIN * off_axis * np.clip(lighter / MIN_PEAK, 0.0, 1.0)
    tint[team[lab[..., 1], lab[..., 2]] >= TEAM_BALLS] = 0.0
    return tint


def _rod_lines(lab: np.ndarray, region: np.ndarray, family: Optional[list[tuple[float, float]]] = None) -> np.ndarray:
    """A mask of the rods' lines (1 on them, each one pixel wide): _rod_family's lines (or the family given) drawn."""
    mask = np.zeros(region.shape, np.uint8)
    h, w = region.shape
    reach = 2 * int(math.hypot(h, w))
    for r, t in (_rod_family(lab, region) if family is None else family):
        c, s = math.cos(t), math.sin(t)
        cv2.line(mask, (round(c * r + s * reach), round(s * r - c * reach)),
                 (round(c * r - s * reach), round(s * r + c * reach)), 1, 1)
    return mask


def _rod_family(lab: np.ndarray, region: np.ndarray) -> list[tuple[float, float]]:
    """The rods' lines as (rho, theta) in work pixels: the straight lines that cross the felt for at least ROD_SPAN of
    its short side with an edge on at least ROD_COVER of that way, within ROD_TURN of the direction most such lines
    share."""
    light = cv2.GaussianBlur(lab[..., 0], (0, 0), 1.0)
    # The edges the rim uses (MIN_EDGE per px; a 3x3 Sobel answers 8 per level per px), hysteresis up to twice that.
    edges = cv2.Canny(light, 8 * MIN_EDGE, 16 * MIN_EDGE)
    (_, _), (rw, rh), _ = cv2.minAreaRect(cv2.findNonZero(region))
    least = ROD_SPAN * min(rw, rh)
    lines = cv2.HoughLines(edges, 1, math.radians(ROD_ANGLE_STEP), max(1, int(least)))
    if lines is None:
        return []
    # An edge within a pixel of the line is on it (the line's angle is quantised).
    near = cv2.dilate(edges, np.ones((3, 3), np.uint8))
    h, w = region.shape
    along = np.arange(-math.hypot(h, w), math.hypot(h, w))
    rods = []
    for rho, theta in lines[:, 0]:
        x = np.rint(math.cos(theta) * rho - math.sin(theta) * along).astype(int)
        y = np.rint(math.sin(theta) * rho + math.cos(theta) * along).astype(int)
        inside = (x >= 0) & (x < w) & (y >= 0) & (y < h)
        xi, yi = x[inside], y[inside]
        on_felt = region[yi, xi] > 0
        way = np.count_nonzero(on_felt)
        if way < least:
            continue
        cover = np.count_nonzero(near[yi[on_felt], xi[on_felt]]) / way
        if cover >= ROD_COVER:
            ends = np.array([[xi[on_felt][0], yi[on_felt][0]], [xi[on_felt][-1], yi[on_felt][-1]]], float)
            rods.append((rho, theta, way * cover, ends))
    rods = _one_line_per_edge(rods)
    if not rods:
        return []
    # The rods' direction: the mean of the lines' directions, weighted by their edges (angles doubled: a line's
    # direction is the same at theta and theta + 180 degrees).
    rho, theta, weight = (np.array(column) for column in zip(*rods))
    common = 0.5 * math.atan2(float(np.sum(weight * np.sin(2 * theta))), float(np.sum(weight * np.cos(2 * theta))))
    family = np.abs((theta - common + math.pi / 2) % math.pi - math.pi / 2) <= math.radians(ROD_TURN)
    return [(float(r), float(t)) for r, t in zip(rho[family], theta[family])]


def _one_line_per_edge(lines: list) -> list:
    """(rho, theta, weight) of the lines (rho, theta, weight, ends: their first and last points on the felt) that
    stand for the others. One edge answers in many nearby (rho, theta) cells, fanning out from where it is clearest
    (or crossing from one of a rod's close stripes to the next). The line with the most edge on it stands for those
    that stay within 2 px of it across the felt: each within a pixel (near's tolerance) of the same edge pixels."""
    kept: list = []
    for line in sorted(lines, key=lambda line: -line[2]):
        if all(np.max(np.abs(line[3] @ (math.cos(other[1]), math.sin(other[1])) - other[0])) > 2.0 for other in kept):
            kept.append(line)
    return [line[:3] for line in kept]


def _offsets(radius: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    n = int(math.ceil(radius))
    yy, xx = np.mgrid[-n:n + 1, -n:n + 1]
    return xx, yy, np.hypot(xx, yy)


def _disc_filter(lighter: np.ndarray, r: float) -> tuple[np.ndarray, np.ndarray]:
    """Per pixel, the best over SCALES of (mean light in a disc) - (mean light in the ring around it), and the disc
    radius that gave it."""
    best = radius = None
    for s in SCALES:
        rr = r * s
        _, _, d = _offsets(RING[1] * rr)
        disc = (d <= rr).astype(np.float32)
        ring = ((d > RING[0] * rr) & (d <= RING[1] * rr)).astype(np.float32)
        answer = (cv2.filter2D(lighter, -1, disc / disc.sum(), borderType=cv2.BORDER_REPLICATE)
                  - cv2.filter2D(lighter, -1, ring / ring.sum(), borderType=cv2.BORDER_REPLICATE))
        if best is None:
            best, radius = answer, np.full(answer.shape, rr, np.float32)
        else:
            better = answer > best
            best = np.where(better, answer, best)
            radius = np.where(better, np.float32(rr), radius)
    return best, radius


def _disc_correlation(lighter: np.ndarray, x: int, y: int, rr: float) -> Optional[float]:
    """Correlation of the light in the disc and its ring with the ideal (1 in the disc, 0 in the ring); None where
    the ring leaves the image."""
    xx, yy, d = _offsets(RING[1] * rr)
    n = xx.shape[0] // 2
    h, w = lighter.shape
    if x - n < 0 or y - n < 0 or x + n >= w or y + n >= h:
        return None
    patch = lighter[y - n:y + n + 1, x - n:x + n + 1]
    inside = d <= rr
    support = inside | ((d > RING[0] * rr) & (d <= RING[1] * rr))
    values, ideal = patch[support], inside[support].astype(np.float32)
    if values.std() <= 1e-6:
        return 0.0
    return float(np.corrcoef(values, ideal)[0, 1])


def _rim(gx: np.ndarray, gy: np.ndarray, x: int, y: int, r: float) -> tuple[float, tuple[float, float]]:
    """How round the light around (x, y) is, at the ball's size: the share of RIM_SECTORS sectors of a circle (radius
    RIM_RADII of r, centre within RIM_SHIFT r of (x, y)) that hold an edge on the circle facing its centre; and
    that circle's centre. Each edge votes for the centre it would have on a circle of that radius (a Hough
    transform); a ball's edges agree on one centre, a straight edge's votes spread along a line."""
    n = int(math.ceil(2.0 * r))
    h, w = gx.shape
    x0, y0, x1, y1 = max(0, x - n), max(0, y - n), min(w, x + n + 1), min(h, y + n + 1)
    wx, wy = gx[y0:y1, x0:x1], gy[y0:y1, x0:x1]
    magnitude = np.hypot(wx, wy)
    ys, xs = np.nonzero(magnitude >= MIN_EDGE)
    best: tuple[float, tuple[float, float]] = (0.0, (float(x), float(y)))
    if len(xs) < 4:
        return best
    # The light rises along the gradient: an edge of a light disc has its centre ahead of it.
    ux, uy = wx[ys, xs] / magnitude[ys, xs], wy[ys, xs] / magnitude[ys, xs]
    shift = int(math.ceil(RIM_SHIFT * r))
    ax0, ay0 = max(0, x - x0 - shift), max(0, y - y0 - shift)
    for factor in RIM_RADII:
        radius = factor * r
        vx, vy = np.rint(xs + radius * ux).astype(int), np.rint(ys + radius * uy).astype(int)
        inside = (vx >= 0) & (vx < x1 - x0) & (vy >= 0) & (vy < y1 - y0)
        votes = np.bincount(vy[inside] * (x1 - x0) + vx[inside], minlength=(y1 - y0) * (x1 - x0))
        votes = cv2.boxFilter(votes.reshape(y1 - y0, x1 - x0).astype(np.float32), -1, (3, 3), normalize=False)
        near = votes[ay0:y - y0 + shift + 1, ax0:x - x0 + shift + 1]
        if near.size == 0:
            continue
        sy, sx = divmod(int(np.argmax(near)), near.shape[1])
        cx, cy = sx + ax0, sy + ay0
        dx, dy = cx - xs, cy - ys
        distance = np.hypot(dx, dy) + 1e-6
        on = ((np.abs(distance - radius) <= max(RIM_TOL_PX, RIM_TOL * radius))
              & ((ux * dx + uy * dy) / distance >= math.cos(math.radians(RIM_ANGLE))))
        angles = np.arctan2(-dy[on], -dx[on])
        sectors = np.unique(((angles + math.pi) / (2 * math.pi) * RIM_SECTORS).astype(int) % RIM_SECTORS)
        share = len(sectors) / RIM_SECTORS
        if share > best[0]:
            best = (share, (float(cx + x0), float(cy + y0)))
    return best


def _pick(candidates: list[StillCandidate], field: Optional[FeltField]) -> Optional[StillCandidate]:
    """The ball, or None. The light comes first: its best candidate is the ball when its score reaches MIN_SCORE
    and it leads every other light candidate more than a ball's width away by MIN_LEAD. Only where the light has no
    clear ball (a ball in a figure's shade shows a thin lit cap) may a tint candidate be the ball, and it must then
    lead every candidate of both cues by MIN_LEAD and reach MIN_TINT_SCORE: a tint is a weaker sign than light, and
    many things are tinted (an end wall's lit beige, a figure whose paint a lamp saturates past its team's colour)."""
    def leader(pool: list[StillCandidate]) -> Optional[StillCandidate]:
        if not pool or pool[0].score < (MIN_SCORE if pool[0].cue == "light" else MIN_TINT_SCORE):
            return None
        return pool[0] if pool[0].score - _rival_score(pool[0], pool, field) >= MIN_LEAD else None

    lit = leader([c for c in candidates if c.cue == "light"])
    return lit if lit is not None else leader(candidates)


def _verified_pick(candidates: list[StillCandidate], field: Optional[FeltField]) -> Optional[StillCandidate]:
    """The ball, or None, with the verifier's chances (StillCandidate.verified) known: the hand-made pick stands unless
    the verifier gives it less than VETO_BELOW; where the rules pick nothing, the candidate the verifier is surest of is the
    ball when it reaches MIN_VERIFIED and leads every candidate more than a ball's width away by MIN_VERIFIED_LEAD."""
    picked = _pick(candidates, field)
    if picked is not None:
        return picked if picked.verified >= VETO_BELOW else None
    pool = sorted(candidates, key=lambda c: -c.verified)
    if not pool or pool[0].verified < MIN_VERIFIED:
        return None
    width = 2.0 * field.ball_radius_px if field is not None else 0.0
    rival = max((c.verified for c in pool[1:] if math.hypot(c.u - pool[0].u, c.v - pool[0].v) > width), default=0.0)
    return pool[0] if pool[0].verified - rival >= MIN_VERIFIED_LEAD else None


def _rival_score(best: StillCandidate, candidates: list[StillCandidate], field: Optional[FeltField]) -> float:
    """The best score among the candidates more than a ball's width from the best (0 when none)."""
    width = 2.0 * field.ball_radius_px if field is not None else 0.0
    rivals = [c.score for c in candidates[1:] if math.hypot(c.u - best.u, c.v - best.v) > width]
    return max(rivals, default=0.0)


def _team_colours(lab: np.ndarray, region: np.ndarray, felt_lab, r: float) -> np.ndarray:
    """Per Lab (a, b), the field's pixels of a chromatic colour within TEAM_TOL of it that are not felt, in balls'
    areas: the figures' team colours stand out by the dozen bodies that wear them."""
    a, b = lab[..., 1].astype(np.int16), lab[..., 2].astype(np.int16)
    felt = (np.abs(a - felt_lab[1]) <= FELT_CHROMA_TOL) & (np.abs(b - felt_lab[2]) <= FELT_CHROMA_TOL)
    chromatic = (np.hypot(a - 128, b - 128) > CHROMATIC) & (region > 0) & ~felt
    counts = np.zeros((256, 256), np.float32)
    np.add.at(counts, (a[chromatic], b[chromatic]), 1.0)
    side = 2 * TEAM_TOL + 1
    return cv2.boxFilter(counts, -1, (side, side), normalize=False, borderType=cv2.BORDER_CONSTANT) / (math.pi * r * r)


def _team_balls(lab: np.ndarray, team: np.ndarray, x: int, y: int, rr: float) -> float:
    """The balls' areas of the field in the colour of the candidate's core (0 when it is white, grey or black)."""
    xx, yy, d = _offsets(0.6 * rr)
    n = xx.shape[0] // 2
    core = lab[y - n:y + n + 1, x - n:x + n + 1][d <= 0.6 * rr].astype(np.float32)
    a, b = (float(v) for v in np.median(core[:, 1:], axis=0))
    if math.hypot(a - 128, b - 128) <= CHROMATIC:
        return 0.0
    return float(team[int(round(a)), int(round(b))])
