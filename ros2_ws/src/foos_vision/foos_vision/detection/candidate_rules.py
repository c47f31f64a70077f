"""Whether a blob is the ball: the rules the tracker applies to BallDetector's candidates.

- Its shape: a whole ball in plain view (`solid`), a ball sure enough to follow or to vote for a colour
  (`confident`), part of a ball (`CandidateRules.partial_ball`).
- Figures of the ball's colour: the steel rods are in front of the ball (a rod's underside is 70 mm up, the
  ball's top 35 mm), so a blob that covers a rod's axis is above the rods, a figure's head (`covers_rod`); a blob
  joined in (nearly) the ball's colour to a stretch of rod it covers is a figure's leg or foot
  (`joined_to_a_covered_rod`); with the figure mask, a partial blob centred on a figure's foot is that foot
  (`on_a_foot`).
- A motion-blurred ball (streaks.py): a streak that is a ball (`streak_ball`), and when one is looked for
  (`streak_search_due`).
- The table's own fixtures: a ball-like blob at the same pixel frame after frame (`Fixtures`).
- Time: how long a track may live on partial blobs alone (`weak_too_long`) and how far apart two sightings of
  one ball may be (`same_ball_reach`).
"""
from __future__ import annotations

import cv2
import numpy as np

from ..camera.field_view import FieldView
from ..camera.rod_lines import STEEL_AB_TOL
from .detector import Candidate, ColourModel
from .streaks import Streak

# Longest a track may live on partly hidden blobs alone: WEAK_TRACK_LIMIT seconds or WEAK_TRACK_FRAMES frames,
# whichever is longer. What tells a ball under a rod from a figure of its colour is the number of frames in
# which the part moves as the ball would; at 25 fps 0.15 s is under 4 frames, less than a ball takes to come
# out from under a rod.
WEAK_TRACK_LIMIT, WEAK_TRACK_FRAMES = 0.15, 8
# Where figures of the ball's colour are guarded against (BallTracker.figures_guarded: the figure mask, or a
# coloured ball, whose figures' heads over their rods are dropped), the rules against them are relaxed: a track
# may live on partial blobs this long (s), and a run of partial blobs starts a track (ball_search.PARTIAL_RUN),
# at rest too (a ball resting half under a rod).
MASKED_WEAK_TRACK_LIMIT = 2.0
MAX_GATE = 0.12  # m: the farthest a track may jump between two frames
ACQUIRE_WINDOW = 0.1  # s: two sightings this close in time confirm a new track (25 fps, or a live feed dropping frames)
MIN_PARTIAL_FILL = 0.4  # share of the inner disc a partly hidden ball must fill
MAX_SPILL = 0.15  # blob pixels 1.25-1.8 radii out / disc area: more, and the blob is merged with something of its colour
MIN_SCORE = 0.2  # candidate score (visible share x roundness) below which a blob is not a ball
# Near a sure prediction a half ball under a rod scores lower (a half disc is 0.5 round, shading takes more of
# its pixels): there it may score this little, if its centre lies within PARTIAL_NEAR radii of the prediction
# and it shows at least PARTIAL_MIN_RATIO of the disc (a thinner sliver's centre is a guess).
PARTIAL_MIN_SCORE, PARTIAL_NEAR, PARTIAL_MIN_RATIO = 0.1, 0.6, 0.28
# A blob with a rod's axis beside its centre mostly in the ball's colour covers the rod: a figure of that colour
# (the rod runs through its body), never the ball, which is below every rod (covers_rod). The axis is looked at
# within ROD_COVER_RADIUS expected radii of the centre and ROD_COVER_ALONG radii along the rod of its nearest
# point; covered when ROD_COVER_SHARE of it is within ROD_COVER_AB times the colour model's a/b tolerance.
# Only for coloured balls: a white ball is as grey as steel's highlights.
ROD_COVER_RADIUS, ROD_COVER_ALONG, ROD_COVER_SHARE, ROD_COVER_AB = 1.3, 0.5, 0.5, 1.6
# Radii from a blob within which pixels of (nearly) its colour joining it to a covered rod's axis make it part of a
# figure: a kicked leg reaches its foot's end 78 mm (4.5 radii) from the axis.
FIGURE_REACH = 5.0
# Radii along the rod between such a blob's centre and the middle of the covered stretch it is joined to, within
# which it is a figure's leg or foot (straight across the rod from its body); a ball touching a figure along the
# rod lies at least its radius and the figure's half width (1.7 radii for a 24 mm body) from the body's middle.
FIGURE_ALONG = 0.8
FIXTURE_FRAMES = 25  # searches that find a blob at the same pixel before it counts as part of the table
# A streak (streaks.py) is a ball when it moved at least STREAK_MIN_MOTION radii during the exposure (less, and the
# ball's disc is whole enough for the colour box), its model explains STREAK_EXPLAINED of the shares' squares around
# it, it rested for at most STREAK_REST of the exposure, it shows STREAK_SEEN of a disc's worth of shares, is
# STREAK_WIDTH of a disc's spread across its axis and its fitted contrast is STREAK_CONTRAST of the learned colour's.
STREAK_MIN_MOTION, STREAK_EXPLAINED, STREAK_REST = 2.0, 0.85, 0.7
# With no track running, a ball that moved SHORT_STREAK_MOTION radii or more is a streak too (BallSearch.short_streak):
# its colour box takes only the middle of its smear, half a disc, which starts no track as a ball.
SHORT_STREAK_MOTION = 1.5
STREAK_SEEN, STREAK_WIDTH, STREAK_CONTRAST = (0.3, 1.6), (0.7, 1.3), (0.6, 1.15)
# And the felt behind its pixels is STREAK_FELT as bright as the median felt, their colour STREAK_BIAS levels or less
# off the plane of the ball's and the felt's, in the median (a red smear for a yellow ball: 0.78 and +9 levels; the
# streaks of a shot render at 1280x720: 0.75-1.05 and -2.6 to +0.1).
STREAK_FELT, STREAK_BIAS = (0.7, 1.3), 4.0
# The streak search runs while the track has seen no ball for at most STREAK_COAST s or STREAK_COAST_FRAMES frames.
STREAK_COAST, STREAK_COAST_FRAMES = 0.1, 3


def weak_too_long(seconds: float, frames: int, masked: bool = False) -> bool:
    """A track has lived on partial blobs alone for too long (both limits passed)."""
    return seconds > (MASKED_WEAK_TRACK_LIMIT if masked else WEAK_TRACK_LIMIT) and frames > WEAK_TRACK_FRAMES


def confident(c: Candidate) -> bool:
    """Nearly the ball's full disc and round: a ball to follow, or to count in the colour vote."""
    return c.streak is None and 0.6 <= c.area_ratio <= 1.5 and c.roundness >= 0.65


def solid(c: Candidate, min_ratio: float = 0.75) -> bool:
    """A whole ball in plain view: nearly the full disc, round, filled, and not part of a larger blob."""
    return (c.streak is None and min_ratio <= c.area_ratio <= 1.3 and c.roundness >= 0.8 and c.fill >= 0.85
            and c.spill <= MAX_SPILL)


def streak_ball(s: Streak, radius: float, min_motion: float = STREAK_MIN_MOTION) -> bool:
    """A ball that moved at least min_motion radii while the shutter was open, and nothing else: its fitted
    model explains the shares around it (a rod's highlight, a figure's lit edge, a hand are not a disc's smear), it
    moved for most of the exposure, enough of the exposure's shares are seen, not more than a ball's worth (a figure
    or a hand of the ball's colour is solid colour over more than a disc), it is as wide as the ball across its axis
    (a path bent by a hit during the exposure is wider: its centre is not measured), the learned colour explains
    its contrast, and its pixels are that colour over felt as bright as the rest (Streak.felt_scale, .bias)."""
    return (s.motion >= min_motion * radius and s.explained >= STREAK_EXPLAINED and s.rest <= STREAK_REST
            and STREAK_SEEN[0] <= s.area_ratio <= STREAK_SEEN[1] and STREAK_WIDTH[0] <= s.width_ratio <= STREAK_WIDTH[1]
            and STREAK_CONTRAST[0] <= s.contrast <= STREAK_CONTRAST[1]
            and STREAK_FELT[0] <= s.felt_scale <= STREAK_FELT[1] and abs(s.bias) <= STREAK_BIAS)


def streak_search_due(seconds: float, frames: int) -> bool:
    """A track that has seen no ball for this long may still find it as a streak: a shot shows in the next frames or
    not at all (after that the search would cover the field, for a ball most often picked up)."""
    return seconds <= STREAK_COAST or frames < STREAK_COAST_FRAMES


def same_ball_reach(view: FieldView, u: float, v: float, seconds: float) -> float:
    """Pixels from (u, v) within which a blob seen `seconds` apart can be the same ball: a radius, and MAX_GATE
    per 0.04 s (at most MAX_GATE)."""
    return view.radius_at_pixel(u, v) + MAX_GATE * view.mapping.pixels_per_metre(view.pixel_to_table(u, v)) * min(
        1.0, seconds / 0.04)


class Fixtures:
    """A ball-like blob that sits at the same pixel frame after frame, while no ball is tracked, is part of the
    table (a screw head, a sticker, a lamp's reflection), not the ball."""

    def __init__(self):
        self._seen: dict[tuple[int, int], int] = {}  # 3 px cell -> searches that found a blob there

    def is_fixture(self, c: Candidate, count: bool = True) -> bool:
        """count: this search's sighting adds to the cell's count (False: only look)."""
        cell = (int(c.u // 3), int(c.v // 3))
        seen = self._seen.get(cell, 0) + (1 if count else 0)
        self._seen[cell] = seen
        return seen > FIXTURE_FRAMES


class CandidateRules:
    """The rules that need the frame and the field's view: figures over or joined to their rods, feet, partial
    balls. `colour` is the ball's colour model the blob was found with."""

    def __init__(self, view: FieldView):
        self.view = view

    def rods_tell_figures(self, colour: ColourModel) -> bool:
        """The rods are placed and the ball is coloured: what covers a rod in (nearly) its colour is a figure."""
        return self.view.rod_axes is not None and colour.hue_lo is not None

    def starts_track(self, bgr: np.ndarray, c: Candidate, colour: ColourModel) -> bool:
        """Confident, and not merged with something of its colour: the end of a figure's bar is a ball-sized,
        roundish blob too, but it goes on past the ball's outline. Nor joined to a figure of its colour: seen
        from the side, a figure's legs below its rod are a round blob of the ball's size."""
        return confident(c) and c.spill <= MAX_SPILL and not self.joined_to_a_covered_rod(bgr, c, colour, strict=True)

    def partial_ball(self, bgr: np.ndarray, c: Candidate, colour: ColourModel) -> bool:
        """Part of a ball: enough of the disc, filled (not a figure's hollow outline), not merged with anything, and
        not joined to a figure of its colour (the end of a kicked leg)."""
        return (c.area_ratio >= 0.4 and c.roundness >= 0.5 and c.fill >= MIN_PARTIAL_FILL and c.spill <= MAX_SPILL
                and not self.on_a_foot(c) and not self.joined_to_a_covered_rod(bgr, c, colour))

    def on_a_foot(self, c: Candidate) -> bool:
        """With the figure mask, the centre of a blob lies on a figure's part below the ball's top. Only the parts
        above are masked (a foot beside the ball can be behind it), so a foot of the ball's colour is still in the
        search: a partial blob centred on one is that foot, or a ball the foot hides the middle of."""
        feet = self.view.feet()
        if feet is None:
            return False
        h, w = feet.shape
        return bool(feet[min(h - 1, max(0, int(round(c.v)))), min(w - 1, max(0, int(round(c.u))))])

    def covers_rod(self, bgr: np.ndarray, c: Candidate, colour: ColourModel) -> bool:
        """The blob lies over a rod's axis, in the ball's colour: a figure of that colour (or anything else above
        the rods), not the ball, which the rods are always in front of."""
        if not self.rods_tell_figures(colour):
            return False
        radius = self.view.radius_at_pixel(c.u, c.v)
        reach = ROD_COVER_RADIUS * radius
        x0, y0, x1, y1 = self._window_around(c, reach)
        ys, xs = np.nonzero(self.view.rod_axes[y0:y1, x0:x1])
        xs, ys = xs + x0, ys + y0
        squared = (xs - c.u) ** 2 + (ys - c.v) ** 2
        inside = squared <= reach * reach
        if np.count_nonzero(inside) < 2:
            return False
        # Only the axis beside the blob's centre, within ROD_COVER_ALONG radii along the rod of the nearest axis
        # point: a figure's head has its middle there and covers only part of the chord within reach.
        inside &= squared <= squared[inside].min() + (ROD_COVER_ALONG * radius) ** 2
        coloured = self._near_ball_colour(np.ascontiguousarray(bgr[ys[inside], xs[inside]][:, None, :]), colour)
        return bool(np.count_nonzero(coloured) >= max(2, ROD_COVER_SHARE * len(coloured)))

    def joined_to_a_covered_rod(self, bgr: np.ndarray, c: Candidate, colour: ColourModel, strict: bool = False) -> bool:
        """Pixels of (nearly) the ball's colour join the blob to a stretch of rod axis they cover: the blob is part
        of a figure of that colour (the end of a kicked leg, a foot), or touches one. strict: pixels of the ball's
        own colour model only; a whole ball in front of a red figure's foot is joined to it in nearly an orange
        ball's colour, while an orange figure's legs are one piece of the ball's colour with its body."""
        if not self.rods_tell_figures(colour):
            return False
        radius = self.view.radius_at_pixel(c.u, c.v)
        x0, y0, x1, y1 = self._window_around(c, FIGURE_REACH * radius)
        axes = self.view.rod_axes[y0:y1, x0:x1] > 0
        if not np.any(axes):
            return False
        window = np.ascontiguousarray(bgr[y0:y1, x0:x1])
        if strict:
            coloured = (colour.mask(cv2.cvtColor(window, cv2.COLOR_BGR2Lab), window) > 0).astype(np.uint8)
        else:
            coloured = self._near_ball_colour(window, colour).astype(np.uint8)
        _, labels = cv2.connectedComponents(coloured, connectivity=8)
        ys, xs = np.nonzero(labels)
        own = labels[ys, xs][(xs + x0 - c.u) ** 2 + (ys + y0 - c.v) ** 2 <= radius * radius]
        if len(own) == 0:
            return False
        blob = np.bincount(own).argmax()
        # A figure's leg or foot lies straight across its rod from the body that covers the axis; a ball beside a
        # figure along the rod is a ball. So the middle of the covered stretch it is joined to must be in line.
        _, lines = cv2.connectedComponents(axes.astype(np.uint8), connectivity=8)
        ay, ax = np.nonzero(axes)
        offsets = np.column_stack([ax + x0 - c.u, ay + y0 - c.v]).astype(float)
        line, joined = lines[ay, ax], labels[ay, ax] == blob
        for rod in np.unique(line[joined]):
            on_rod = line == rod
            if np.count_nonzero(joined & on_rod) < 2:
                continue
            # The rod's direction here: the principal axis of its pixels in the window.
            spread = np.cov(offsets[on_rod].T)
            direction = np.linalg.eigh(spread)[1][:, -1]
            if abs(float(np.mean(offsets[joined & on_rod] @ direction))) <= FIGURE_ALONG * radius:
                return True
        return False

    def _window_around(self, c: Candidate, reach: float) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) of the frame's pixels within reach of the candidate's centre, clipped to the frame."""
        h, w = self.view.rod_axes.shape
        return (max(0, int(c.u - reach)), max(0, int(c.v - reach)),
                min(w, int(c.u + reach) + 2), min(h, int(c.v + reach) + 2))

    def _near_ball_colour(self, bgr: np.ndarray, model: ColourModel) -> np.ndarray:
        """Pixels of a colour near the ball's and not grey like the steel (bool, the image's shape less its
        channels): a red figure passes for an orange ball by its orange-lit edges only, so the box is wider."""
        ab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab)[..., 1:].astype(np.int16)
        near = ((np.abs(ab[..., 0] - model.a) <= ROD_COVER_AB * model.ab_tol)
                & (np.abs(ab[..., 1] - model.b) <= ROD_COVER_AB * model.ab_tol))
        felt_ab = self.view.felt_ab
        if felt_ab is not None:
            # The wider box reaches the green felt's lighter threads from a yellow ball: nearer the felt is felt.
            a, b = ab[..., 0].astype(np.float32), ab[..., 1].astype(np.float32)
            to_ball = (a - model.a) ** 2 + (b - model.b) ** 2
            to_felt = (a - felt_ab[0]) ** 2 + (b - felt_ab[1]) ** 2
            near &= to_ball < to_felt
        return near & (np.maximum(np.abs(ab[..., 0] - 128), np.abs(ab[..., 1] - 128)) > 1.5 * STEEL_AB_TOL)
