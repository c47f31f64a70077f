"""Where the ball is in a frame: the searches the tracker runs. Each returns (candidate, Lab pixels, roi) of the
blob it settles on, or (None, ...) (the Lab pixels and their roi give the colour learning the ball's pixels).

- `near`: around a running track's prediction; the gate grows while the track coasts.
- `solid_elsewhere`: a whole ball away from the partial blob a weak track follows.
- `on_field`: anywhere on the field, for a new track (at half resolution where the ball is big enough there;
  the blobs that nearly pass are measured again at full resolution). It remembers the partial balls it saw,
  and `partial_run` starts a track on a run of them.
- `streak`: a motion-blurred ball (a shot) within a shot's reach of the track's last detection (streaks.py), in the
  ball's colour as learned from the whole balls seen (`note_whole_ball`).
- `short_streak`: with no track running, a streak around a partial ball of the latest field search (a ball rolling a
  little too fast for its colour box to take it whole), a sighting toward a new track.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from ..camera.field_view import FieldView
from .candidate_rules import (
    ACQUIRE_WINDOW,
    MAX_GATE,
    MAX_SPILL,
    MIN_PARTIAL_FILL,
    MIN_SCORE,
    PARTIAL_MIN_RATIO,
    PARTIAL_MIN_SCORE,
    PARTIAL_NEAR,
    SHORT_STREAK_MOTION,
    STREAK_WIDTH,
    CandidateRules,
    Fixtures,
    confident,
    same_ball_reach,
    solid,
    streak_ball,
)
from .detector import FELT_AB_TOL, BallDetector, Candidate, ColourModel
from .motion_ball import SCALE as MOTION_SCALE
from .motion_ball import MotionMap
from .streaks import Streak, find_streaks

BAND_SEEDS_NEAR = False
COAST_SPEED = 1.5  # m/s: the speed change a hit can give a hidden ball, for the gate while a track coasts
HALF_RES_RATIO, HALF_RES_ROUNDNESS = 0.3, 0.4  # field search at half resolution: blobs worth a full-resolution look
# Where figures are guarded against, a new track from partial blobs alone: this many frames running of a partly
# hidden ball (a ball coming out from under a rod, or resting beside one, while no track runs) whose centres lie
# on one straight, steady path (within PARTIAL_RUN_FIT m RMS), moving or at rest. Never otherwise (a white ball
# without the mask): a figure of the ball's colour sliding with its rod (or at rest) makes such a run. 0: off.
PARTIAL_RUN, PARTIAL_RUN_FIT = 4, 0.003
NOTHING = (None, None, None)
SHOT_SPEED = 12.0  # m/s: the fastest shot the streak search reaches for from the track's last detection
# A streak's centre along its axis is less sure than across it (an end under a figure, a hit during the exposure):
# sigma along = hypot(the filter's measurement_std, STREAK_ALONG * the motion during the exposure).
STREAK_ALONG = 0.03
# The second moments of a streak half behind a figure say it moved less than the fit finds: blobs that moved this
# many radii by their moments are fitted (CandidateRules: STREAK_MIN_MOTION by the fit).
STREAK_MOMENT_MOTION = 1.2
STREAK_FROM = 2.0  # radii: see BallSearch.streak_from
# A short streak (no track running) is looked for around the SHORT_STREAK_LOOKS best partial balls of the field search,
# in a window SHORT_STREAK_WINDOW radii from their centres (a smear of 2 radii plus a disc, with room for a rod across).
SHORT_STREAK_LOOKS, SHORT_STREAK_WINDOW = 2, 4.0
# Near a prediction, a moved blob of fewer shares than this (but at least motion_ball.SHARES_RANGE's 0.2: a ball half
# under a foot) counts only within PARTIAL_NEAR radii (plus 2 sigma) of it.
MOVED_NEAR_SHARES = 0.3
# The ball's radius (px) at the background's resolution below which no moved blob is looked at: a ball of 3 px there
# (6 px in the frame) is a few dozen pixels, whose shares, width and roundness are at the level of compression noise
# and figures' edges. On the 640x480 renders (4-6 px) the moved blobs found were 6-26 mm off the ball, took a red figure
# on the oblique orange case (p95 3.1 -> 185 mm, 33 false detections per 1000 hidden frames, before the 1.5-disc
# limit) and a red figure that swung into view on the 30 fps orange shots (25 per 1000).
MOTION_MIN_RADIUS = 3.5
BALL_COLOUR_SAMPLES = 40  # whole balls in plain view whose mean colour is the streak search's ball colour


@dataclass(frozen=True)
class SearchWindow:
    """Where to look for the ball: the track's position at time t and its uncertainty. Tracking fills it in (from its
    filter's state); the searches read only these, so detection needs nothing of tracking."""
    t: float  # s
    position: np.ndarray  # (x, y) in the table frame, m
    covariance: np.ndarray  # the position's, 2x2, m^2


class BallSearch:
    """The searches of one tracker, with the ball's colour they look for (`detector`, replaced when the colour
    is voted or learned) and what they remember: the table's fixtures and the partial balls of recent frames."""

    def __init__(self, view: FieldView, detector: BallDetector):
        self.view = view
        self.detector = detector
        self.rules = CandidateRules(view)
        self.fixtures = Fixtures()
        self._field_lab = None  # Lab pixels of the latest full-resolution field search (of view.roi)
        self._partial_history: deque = deque(maxlen=max(1, PARTIAL_RUN))  # (t, [found tuples]) of field searches
        self._whole_colours: deque = deque(maxlen=BALL_COLOUR_SAMPLES)  # mean BGR of the whole balls seen
        self._felt: tuple = (None, None)  # (view.felt_ab it was taken for, the felt's median BGR)
        # The tracker's last detection was a streak: the track knows the ball less well (where along the streak, how
        # fast), and a blob next frame is judged as after a frame without the ball (near: a figure of its colour
        # where a shot went into the goal does not carry the track).
        self.after_streak = False
        self.motion = MotionMap()  # the tracker shows it every frame (MotionMap.look)

    @property
    def colour(self) -> ColourModel:
        return self.detector.model

    def near(self, bgr: np.ndarray, window: SearchWindow, coast: float = 0.0, coast_frames: int = 0):
        """The ball near the track's prediction (window); coast: seconds since the last detection, coast_frames: frames."""
        view = self.view
        coast_frames = max(coast_frames, int(self.after_streak))
        ppm = view.mapping.pixels_per_metre(window.position)
        radius = view.table.ball_radius * ppm
        sigma = math.sqrt(max(np.linalg.eigvalsh(window.covariance).max(), 0.0)) * ppm
        # While the ball is hidden it may be hit (a foot, a wall): the longer the track coasts, the further
        # from the prediction a whole ball may reappear.
        gate = min(4.0 * sigma + COAST_SPEED * coast * ppm, MAX_GATE * ppm) + 1.5 * radius + 2.0
        centre = view.table_to_pixel(window.position)
        found, lab, roi = self._window(bgr, centre, gate, gate + 2 * radius + 2, use_band=True,
                                       band_seeds=BAND_SEEDS_NEAR, partial_reach=PARTIAL_NEAR * radius + 2.0 * sigma)
        offset = math.inf if found is None else math.hypot(found.u - centre[0], found.v - centre[1])
        if found is not None and found.spill > MAX_SPILL and (coast_frames > 0 or offset > PARTIAL_NEAR * radius
                                                                + 2.0 * sigma):
            # Merged with something of its colour (a ball against a figure, or a figure's bar alone): its centre
            # is pulled toward the figure, so it only carries a track that has not lost the ball, and only
            # where the ball is expected. A coasting track would slide onto the figure.
            return None, lab, roi
        if found is not None and not solid(found) and self.rules.on_a_foot(found):
            return None, lab, roi
        if found is not None and not confident(found):
            # A partly hidden ball is followed only where it is expected; further out, only a whole ball
            # counts, so a figure of the ball's colour cannot take the track over.
            if offset > min(gate, 2.0 * radius + 2 * sigma + 2.0):
                return None, lab, roi
            # After the ball has been lost for a few frames, the outline of a figure (its edge pixels blend
            # into the ball's hue) must not restart the track: it is a thin ring with little inside, while a
            # ball coming out from under a foot shows a solid part. (A rod across a tracked ball's middle
            # also empties its inside, so this holds only while coasting.)
            if coast_frames >= 2 and found.fill < MIN_PARTIAL_FILL:
                return None, lab, roi
        # Nor may a track that has lost the ball go on with a figure of its colour, joined in (nearly) that
        # colour to the rod it covers: the end of a kicked leg (the hands video: the leg beside the hand that had
        # just picked the ball up), or, seen from the side, the legs below the rod. Not before the ball is lost:
        # a ball touching a figure of its colour is that too (applied in every frame: recall -1 to -7 points in
        # six red and orange videos).
        if found is not None and coast_frames >= 1 and self.rules.joined_to_a_covered_rod(
                bgr, found, self.colour, strict=confident(found)):
            return None, lab, roi
        return found, lab, roi

    def streak(self, bgr: np.ndarray, predicted: SearchWindow, last: SearchWindow):
        """A motion-blurred ball within a shot's reach (SHOT_SPEED) of the last detection (`last`, the filter's state
        then), nearest the prediction: a candidate with its `streak`, or nothing. Not a figure over its rod."""
        view = self.view
        since = max(predicted.t - last.t, 0.0)
        ppm = view.mapping.pixels_per_metre(last.position)
        radius = view.table.ball_radius * ppm
        sigma = math.sqrt(max(np.linalg.eigvalsh(last.covariance).max(), 0.0)) * ppm
        reach = (SHOT_SPEED * since) * ppm + 3.0 * sigma + radius
        start = view.table_to_pixel(last.position)
        expected = view.table_to_pixel(predicted.position)
        roi = _square(view.roi, start, reach + radius)
        if roi is None:
            return NOTHING
        found = []
        for s in find_streaks(bgr, roi, view.radius_at_pixel, self._ball_colour(), self.felt_colour(bgr),
                              view.active_region, min_motion=STREAK_MOMENT_MOTION, width=STREAK_WIDTH,
                              near=(float(expected[0]), float(expected[1])), rod_axes=self._figure_axes()):
            r = view.radius_at_pixel(s.u, s.v)
            if not streak_ball(s, r) or math.hypot(s.u - start[0], s.v - start[1]) > reach:
                continue
            c = _streak_candidate(s)
            if not self.rules.covers_rod(bgr, c, self.colour):
                found.append(c)
        if not found:
            return NOTHING
        return min(found, key=lambda c: math.hypot(c.u - expected[0], c.v - expected[1])), None, roi

    def short_streak(self, bgr: np.ndarray):
        """With no track running: a ball that moved SHORT_STREAK_MOTION radii or more during the exposure, around one
        of the partial balls the latest field search saw (on_field): the colour box takes only the middle of such a
        smear, half a disc, too little to start a track as a ball. A candidate with its `streak`, or nothing. Not a
        figure over its rod, nor one joined to a figure of its colour (the partial balls are neither)."""
        if not self._partial_history:
            return NOTHING
        view = self.view
        rod_axes = self._figure_axes()
        for c, _, _ in sorted(self._partial_history[-1][1], key=lambda f: -f[0].score)[:SHORT_STREAK_LOOKS]:
            radius = view.radius_at_pixel(c.u, c.v)
            roi = _square(view.roi, (c.u, c.v), SHORT_STREAK_WINDOW * radius)
            if roi is None:
                continue
            for s in find_streaks(bgr, roi, view.radius_at_pixel, self._ball_colour(), self.felt_colour(bgr),
                                  view.active_region, min_motion=STREAK_MOMENT_MOTION, width=STREAK_WIDTH,
                                  near=(c.u, c.v), most=1, rod_axes=rod_axes):
                # The partial ball is the smear's middle: the streak's centre lies within a radius of it.
                if streak_ball(s, radius, SHORT_STREAK_MOTION) and math.hypot(s.u - c.u, s.v - c.v) <= radius:
                    candidate = _streak_candidate(s)
                    if not self.rules.covers_rod(bgr, candidate, self.colour):
                        return candidate, None, roi
        return NOTHING

    def _figure_axes(self) -> Optional[np.ndarray]:
        """The rods' axes for the streak search, where they tell figures of the ball's colour (a coloured ball)."""
        return self.view.rod_axes if self.rules.rods_tell_figures(self.colour) else None

    def streak_from(self, c: Candidate, last: SearchWindow) -> bool:
        """The streak's line passes within STREAK_FROM radii (and 3 sigma) of the last detection: the ball can have
        gone along it from there, struck or rolling on. A streak that does not is no match for a partly hidden ball
        where the track expects it (a figure's lit edge, a hand, passes for a streak now and then)."""
        view = self.view
        start = view.table_to_pixel(last.position)
        ppm = view.mapping.pixels_per_metre(last.position)
        sigma = math.sqrt(max(np.linalg.eigvalsh(last.covariance).max(), 0.0)) * ppm
        axis = c.streak.axis  # distance of the last detection from the streak's line (a 2-D cross product)
        off = abs(float(axis[0] * (start[1] - c.v) - axis[1] * (start[0] - c.u)))
        return off <= STREAK_FROM * view.radius_at_pixel(c.u, c.v) + 3.0 * sigma

    def moved_near(self, bgr: np.ndarray, window: SearchWindow, coast: float = 0.0):
        """The ball's colour where the table changed (motion_ball), within the gate of `near` around the prediction:
        a ball the colour box misses (streaked, dimmed, half under a foot)."""
        view = self.view
        ppm = view.mapping.pixels_per_metre(window.position)
        radius = view.table.ball_radius * ppm
        if radius * MOTION_SCALE < MOTION_MIN_RADIUS:
            return NOTHING
        sigma = math.sqrt(max(np.linalg.eigvalsh(window.covariance).max(), 0.0)) * ppm
        gate = min(4.0 * sigma + COAST_SPEED * coast * ppm, MAX_GATE * ppm) + 1.5 * radius + 2.0
        centre = view.table_to_pixel(window.position)
        for blob in self.motion.blobs(self._ball_colour(), view.radius_at_pixel, centre, gate, self.felt_colour(bgr)):
            # Part of a ball (under a foot, a figure's edge across it) only where one is expected, as for the colour
            # box's partial blobs (PARTIAL_NEAR).
            partial_reach = PARTIAL_NEAR * radius + 2.0 * sigma
            if blob.shares < MOVED_NEAR_SHARES and math.hypot(blob.u - centre[0], blob.v - centre[1]) > partial_reach:
                continue
            c = blob.candidate()
            if not self.rules.covers_rod(bgr, c, self.colour):
                return c, None, None
        return NOTHING

    def measurement_covariance(self, c: Candidate, std: float) -> Optional[np.ndarray]:
        """The covariance (m^2, table frame) of a streak's centre, elongated along it; None for a ball seen as a disc
        (the filter's own, std round)."""
        if c.streak is None:
            return None
        half = c.streak.axis * c.streak.motion / 2
        ends = [self.view.pixel_to_table(c.u + sign * half[0], c.v + sign * half[1]) for sign in (-1.0, 1.0)]
        along = ends[1] - ends[0]
        motion = float(np.linalg.norm(along))
        if motion <= 0:
            return None
        direction = along / motion
        sigma_along = math.hypot(std, STREAK_ALONG * motion)
        return std * std * np.eye(2) + (sigma_along ** 2 - std * std) * np.outer(direction, direction)

    def note_whole_ball(self, bgr: np.ndarray, c: Candidate) -> None:
        """A whole ball in plain view: its mean colour (within 0.8 radii) is what a streak is a share of."""
        radius = self.view.radius_at_pixel(c.u, c.v)
        reach = int(math.ceil(0.8 * radius))
        x, y = int(round(c.u)), int(round(c.v))
        if x - reach < 0 or y - reach < 0 or x + reach >= bgr.shape[1] or y + reach >= bgr.shape[0]:
            return
        patch = bgr[y - reach:y + reach + 1, x - reach:x + reach + 1].reshape(-1, 3).astype(np.float64)
        yy, xx = np.mgrid[y - reach:y + reach + 1, x - reach:x + reach + 1]
        inside = ((xx - c.u) ** 2 + (yy - c.v) ** 2 <= (0.8 * radius) ** 2).ravel()
        if np.count_nonzero(inside) >= 5:
            self._whole_colours.append(patch[inside].mean(axis=0))

    def _ball_colour(self) -> np.ndarray:
        """The ball's mean BGR: the median of the whole balls seen, else the colour model's centre."""
        if self._whole_colours:
            return np.median(np.array(self._whole_colours), axis=0)
        m = self.colour
        lab = np.array([[[(m.l_min + m.l_max) / 2, m.a, m.b]]], np.uint8)
        return cv2.cvtColor(lab, cv2.COLOR_Lab2BGR)[0, 0].astype(np.float64)

    def felt_colour(self, bgr: np.ndarray) -> np.ndarray:
        """The bare felt's median BGR, taken again whenever the view's felt colour (Lab a, b) is."""
        felt_ab = self.view.felt_ab
        if self._felt[0] is None or self._felt[0] != felt_ab:
            x0, y0, x1, y1 = self.view.roi
            pixels = np.ascontiguousarray(bgr[y0:y1:4, x0:x1:4])
            lab = cv2.cvtColor(pixels, cv2.COLOR_BGR2Lab).astype(np.int16)
            bare = self.view.region[y0:y1:4, x0:x1:4] > 0
            if felt_ab is not None:
                bare &= ((np.abs(lab[..., 1] - felt_ab[0]) <= FELT_AB_TOL) & (np.abs(lab[..., 2] - felt_ab[1]) <= FELT_AB_TOL))
            self._felt = (felt_ab, np.median(pixels[bare].astype(np.float64), axis=0) if np.any(bare) else
                          np.median(pixels.reshape(-1, 3).astype(np.float64), axis=0))
        return self._felt[1]

    def solid_elsewhere(self, bgr: np.ndarray, tracked: Candidate):
        """A whole ball away from the tracked blob, found with the shading-tolerant colour (or nothing); not a
        figure's legs (CandidateRules.starts_track)."""
        radius = self.view.radius_at_pixel(tracked.u, tracked.v)
        loose = [c for c in self._field(bgr) if c.area_ratio >= 0.4 and c.roundness >= 0.6
                 and math.hypot(c.u - tracked.u, c.v - tracked.v) >= 3 * radius
                 and not self.fixtures.is_fixture(c, count=False)]
        for c in sorted(loose, key=lambda c: -c.score)[:3]:
            r = self.view.radius_at_pixel(c.u, c.v)
            found = self._window(bgr, np.array([c.u, c.v]), 2 * r + 3, 2 * r + 3, use_band=True)
            if (found[0] is not None and solid(found[0]) and found[0].score >= tracked.score + 0.15
                    and not self.rules.joined_to_a_covered_rod(bgr, found[0], self.colour, strict=True)):
                return found
        return NOTHING

    def on_field(self, bgr: np.ndarray, t: float):
        """The best blob on the field to start a track on; the partial balls seen are kept for partial_run."""
        partials: list = []
        found = self._best_on_field(bgr, partials)
        self._partial_history.append((t, partials))
        return found

    def forget_partials(self) -> None:
        """A track started: the partial balls seen so far start no other."""
        self._partial_history.clear()

    def _best_on_field(self, bgr: np.ndarray, partials: list):
        candidates = self._field(bgr)
        colour, roi = self.colour, self.view.roi
        if self.view.search_scale == 1.0:
            good = [c for c in candidates if self.rules.starts_track(bgr, c, colour) and not self.fixtures.is_fixture(c)]
            if not good:
                partials += [(c, self._field_lab, roi) for c in candidates
                             if self.rules.partial_ball(bgr, c, colour) and not self.fixtures.is_fixture(c, count=False)]
            return (max(good, key=lambda c: c.score), self._field_lab, roi) if good else NOTHING
        # Found at half resolution, where a ball of a few pixels looks less round and smaller than it is: the
        # blobs that nearly pass are measured again on the full-resolution pixels around them, and judged there.
        near_misses = [c for c in candidates if c.area_ratio >= HALF_RES_RATIO and c.roundness >= HALF_RES_ROUNDNESS
                       and not self.fixtures.is_fixture(c)]
        for c in sorted(near_misses, key=lambda c: -c.score)[:3]:
            radius = self.view.radius_at_pixel(c.u, c.v)
            found = self._window(bgr, np.array([c.u, c.v]), 2 * radius + 3, 2 * radius + 3)
            if found[0] is not None and self.rules.starts_track(bgr, found[0], colour):
                return found
            if found[0] is not None and self.rules.partial_ball(bgr, found[0], colour):
                partials.append(found)
        return NOTHING

    def partial_run(self, figures_guarded: bool):
        """A new track from PARTIAL_RUN frames running of partial blobs on one steady path (or nothing); only
        where figures are guarded against: a figure sliding with its rod is a partial blob on a steady path too."""
        history = list(self._partial_history)
        if PARTIAL_RUN < 2 or len(history) < PARTIAL_RUN or not figures_guarded:
            return NOTHING
        history = history[-PARTIAL_RUN:]
        if any(b[0] - a[0] > ACQUIRE_WINDOW for a, b in zip(history, history[1:])):
            return NOTHING
        for found in history[-1][1]:
            chain = [(history[-1][0], found[0])]
            for t_prev, previous in reversed(history[:-1]):
                t_last, last = chain[-1]
                reach = same_ball_reach(self.view, last.u, last.v, t_last - t_prev)
                near = [f[0] for f in previous if math.hypot(f[0].u - last.u, f[0].v - last.v) <= reach]
                if not near:
                    break
                chain.append((t_prev, min(near, key=lambda c: math.hypot(c.u - last.u, c.v - last.v))))
            if len(chain) < PARTIAL_RUN:
                continue
            ts = np.array([t for t, _ in chain])
            xy = np.array([self.view.pixel_to_table(c.u, c.v) for _, c in chain])
            design = np.stack([np.ones_like(ts), ts - ts[0]], axis=1)
            coef, *_ = np.linalg.lstsq(design, xy, rcond=None)
            residual = float(np.sqrt(np.mean(np.sum((design @ coef - xy) ** 2, axis=1))))
            if residual <= PARTIAL_RUN_FIT:
                return found
        return NOTHING

    def _field(self, bgr: np.ndarray) -> list[Candidate]:
        """Candidates anywhere on the field; at half resolution when the ball is big enough (4x cheaper)."""
        view = self.view
        s = view.search_scale
        if s == 1.0:
            candidates, self._field_lab, _ = self.detector.candidates(bgr, view.roi, view.radius_at_pixel,
                                                                      view.min_radius, view.active_region,
                                                                      use_band=False, hidden=view.hidden,
                                                                      felt_ab=view.felt_ab)
            return [c for c in candidates if not self.rules.covers_rod(bgr, c, self.colour)]
        x0, y0, x1, y1 = view.roi
        small = cv2.resize(bgr[y0:y1, x0:x1], None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        h, w = small.shape[:2]
        # Every blob found here is measured again at full resolution before it counts: no outline fits.
        candidates, _, _ = self.detector.candidates(
            small, (0, 0, w, h), lambda u, v: s * view.radius_at_pixel(x0 + (u + 0.5) / s - 0.5, y0 + (v + 0.5) / s - 0.5),
            s * view.min_radius, view.active_region_small, use_band=False, fit_outline=False)
        for c in candidates:
            c.u, c.v = x0 + (c.u + 0.5) / s - 0.5, y0 + (c.v + 0.5) / s - 0.5
        return candidates

    def _window(self, bgr: np.ndarray, centre: np.ndarray, gate: float, half: float, use_band: bool = False,
                band_seeds: bool = False, partial_reach: float = 0.0):
        """The best candidate within gate px of centre, searched in a square of half width half. Blobs that
        score too low for a ball count only within partial_reach px (a half ball where one is expected)."""
        view = self.view
        h, w = bgr.shape[:2]
        roi = _square((0, 0, w, h), centre, half)
        if roi is None:
            return NOTHING
        candidates, lab, _ = self.detector.candidates(bgr, roi, view.radius_at_pixel, view.min_radius,
                                                      view.active_region, use_band=use_band, band_seeds=band_seeds,
                                                      hidden=view.hidden, felt_ab=view.felt_ab)
        near = [c for c in candidates if math.hypot(c.u - centre[0], c.v - centre[1]) <= gate
                and (c.score > MIN_SCORE or (c.score > PARTIAL_MIN_SCORE and c.area_ratio >= PARTIAL_MIN_RATIO
                                             and math.hypot(c.u - centre[0], c.v - centre[1]) <= partial_reach))
                and not self.rules.covers_rod(bgr, c, self.colour)]
        if not near:
            return None, lab, roi
        best = min(near, key=lambda c: math.hypot(c.u - centre[0], c.v - centre[1]) / gate - c.score)
        return best, lab, roi


def _square(bounds: tuple[int, int, int, int], centre, half: float) -> Optional[tuple[int, int, int, int]]:
    """(x0, y0, x1, y1): the pixels within half of centre (u, v), clipped to bounds; None when under 3 px a side."""
    x0, y0 = max(bounds[0], int(centre[0] - half)), max(bounds[1], int(centre[1] - half))
    x1, y1 = min(bounds[2], int(centre[0] + half) + 1), min(bounds[3], int(centre[1] + half) + 1)
    return (x0, y0, x1, y1) if x1 - x0 >= 3 and y1 - y0 >= 3 else None


def _streak_candidate(s: Streak) -> Candidate:
    """A streak as a candidate: its share of a disc seen, its roundness the second moments', and the streak."""
    roundness = 1.0 / math.sqrt(1.0 + s.motion ** 2 / (3.0 * s.radius ** 2))
    return Candidate(s.u, s.v, s.area_ratio, roundness, min(s.area_ratio, 1.0), streak=s)
