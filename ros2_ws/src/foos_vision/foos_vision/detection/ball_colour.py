"""The ball's colour: the `auto` vote over the colour prototypes (ColourVote, MovingBallVotes); when none of them
fits the ball, its colour learned from the round, ball-sized thing that moves (MotionColourVote); and, with
TrackerConfig.learn_after, the colour box re-centred on the ball seen (ColourLearner)."""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from ..camera.field_view import FieldView
from ..camera.rod_lines import on_rod_line
from .candidate_rules import confident
from .detector import BALL_COLOR_NAMES, BallDetector, Candidate, ColourModel, colour_model

AUTO_MIN_SHARE = 0.3  # auto colour: share of the frames looked at in which the winner saw one moving ball
# Auto colour votes over at most this many recent frames: a live feed with no ball in view for minutes must
# not make every frame compare its blobs with all frames so far (the bench's videos settle within 120).
AUTO_WINDOW = 300
# A blob in a rod's band seen again this close in ball-plane y (m) and at least this far along x (m) is a figure
# sliding with its rod, for the auto colour vote (rod_lines).
ROD_LINE_Y_TOL, ROD_LINE_MIN_DX = 0.004, 0.010


class ColourVote:
    """Auto colour: which prototype finds one round, ball-sized blob that moves, most often."""

    def __init__(self):
        self._seen: dict[str, MovingBallVotes] = {}  # per colour, made at the first vote (the rod bands are known)

    def vote(self, bgr: np.ndarray, view: FieldView, enough_frames: bool) -> tuple[Optional[str], bool]:
        """Count this frame; (the colour ahead, None while no colour has a vote; whether the vote is settled).
        enough_frames: the tracker has looked at the frames it wants at least (TrackerConfig.auto_frames)."""
        for name in BALL_COLOR_NAMES:
            detector = BallDetector(colour_model(name))
            candidates, _, _ = detector.candidates(bgr, view.roi, view.radius_at_pixel, view.min_radius,
                                                   view.active_region, use_band=False)
            if name not in self._seen:
                self._seen[name] = MovingBallVotes()
            self._seen[name].bands = view.rod_bands  # the latest tag fit's
            self._seen[name].add([(c.u, c.v, *view.pixel_to_table(c.u, c.v)) for c in candidates if confident(c)])
        votes = {name: self._seen[name].votes() for name in BALL_COLOR_NAMES}
        ranked = sorted(BALL_COLOR_NAMES, key=lambda n: -votes[n])
        best, second = ranked[0], ranked[1]
        # Settle only on clear evidence: a figure of one colour passes for a ball now and then (a red figure
        # moving with its rod in a fifth of the frames while an orange ball was half hidden), a ball in view
        # does so in most frames.
        voted = self._seen[best].frames
        settled = (enough_frames and votes[best] >= max(3, AUTO_MIN_SHARE * voted)
                   and votes[best] >= 2 * votes[second])
        return (best if votes[best] > 0 else None), settled


class MovingBallVotes:
    """Auto colour's count for one colour: frames with exactly one blob (u, v pixels, x, y on the ball plane)
    that is neither a fixture nor a figure, over the last AUTO_WINDOW frames.

    A fixture: a blob found again at the same pixel (2 px) in a frame at least 6 frames away (part of the
    table, or a figure at rest). A figure sliding with its rod: a blob inside a rod's band (rod_lines) found
    again, 6 or more frames away, on the same line of y (ROD_LINE_Y_TOL) at another x (ROD_LINE_MIN_DX): a
    figure's ball-plane y stays on its rod's line, a ball's does not. Each blob keeps a count of the blobs in
    the window that make it a fixture or a figure, so a frame costs one comparison with the window, not a
    comparison of every pair (a live feed may wait long for its ball).
    """

    APART = 6  # frames

    def __init__(self, bands: Optional[np.ndarray] = None, window: int = AUTO_WINDOW):
        self.bands, self.window = bands, window
        self.frames = 0  # frames in the window
        self._first = 0  # index of the window's first frame
        self._frame = np.zeros(0, dtype=int)
        self._blob = np.zeros((0, 4))
        self._on_line = np.zeros(0, dtype=bool)
        self._static = np.zeros(0, dtype=int)  # blobs in the window at this blob's pixel
        self._along = np.zeros(0, dtype=int)  # blobs in the window on this blob's line of y, elsewhere in x

    def _matches(self, blobs: np.ndarray, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(len(blobs), N) fixture and rod-line matches of `blobs` (in frames `frame`) with the window's blobs."""
        apart = np.abs(frame[:, None] - self._frame[None, :]) >= self.APART
        same_pixel = np.hypot(blobs[:, None, 0] - self._blob[None, :, 0], blobs[:, None, 1] - self._blob[None, :, 1]) < 2.0
        along = ((np.abs(blobs[:, None, 3] - self._blob[None, :, 3]) < ROD_LINE_Y_TOL)
                 & (np.abs(blobs[:, None, 2] - self._blob[None, :, 2]) >= ROD_LINE_MIN_DX))
        return apart & same_pixel, apart & along

    def add(self, blobs: list[tuple[float, float, float, float]]) -> None:
        """The next frame's blobs."""
        index = self._first + self.frames
        if self.frames == self.window:
            leaving = self._frame == self._first
            static, along = self._matches(self._blob[leaving], self._frame[leaving])
            keep = ~leaving
            self._static = (self._static - static.sum(0))[keep]
            self._along = (self._along - along.sum(0))[keep]
            self._frame, self._blob, self._on_line = self._frame[keep], self._blob[keep], self._on_line[keep]
            self._first += 1
        else:
            self.frames += 1
        new = np.array(blobs, dtype=float).reshape(-1, 4)
        frame = np.full(len(new), index)
        static, along = self._matches(new, frame)
        self._static = np.concatenate([self._static + static.sum(0), static.sum(1)])
        self._along = np.concatenate([self._along + along.sum(0), along.sum(1)])
        on_line = (np.array([on_rod_line(y, self.bands) for y in new[:, 3]], dtype=bool) if self.bands is not None
                   else np.zeros(len(new), dtype=bool))
        self._frame = np.concatenate([self._frame, frame])
        self._blob = np.concatenate([self._blob, new])
        self._on_line = np.concatenate([self._on_line, on_line])

    def moving_blobs(self) -> list[tuple[int, int]]:
        """(frame, the blob's place among that frame's blobs) of each blob that is neither a fixture nor a figure."""
        moving = self._moving()
        found = []
        for frame in np.unique(self._frame):
            here = moving[self._frame == frame]
            found += [(int(frame), int(k)) for k in np.flatnonzero(here)]
        return found

    def _moving(self) -> np.ndarray:
        return (self._static == 0) & ~(self._on_line & (self._along > 0))

    def votes(self) -> int:
        moving = self._moving()
        per_frame = np.bincount(self._frame[moving] - self._first, minlength=self.frames)
        return int(np.sum(per_frame == 1))


class MotionColourVote:
    """Auto colour with no prototype: the colour of the round, ball-sized blobs that move (motion_ball.moved), counted
    as the prototypes are (MovingBallVotes: not a fixture, not a figure sliding with its rod). Taken once it is clear:
    among the moving blobs lighter than the felt, one colour at least MOTION_MIN_VOTES times and twice as often as any
    other (see model)."""

    def __init__(self):
        self._votes = MovingBallVotes()
        self._cores: dict[int, list[np.ndarray]] = {}  # frame -> mean BGR of each blob's core, in the votes' order
        self._frame = -1

    def add(self, blobs: list[tuple[float, float, np.ndarray]], view: FieldView) -> None:
        self._votes.bands = view.rod_bands
        self._votes.add([(u, v, *view.pixel_to_table(u, v)) for u, v, _ in blobs])
        self._frame += 1
        self._cores[self._frame] = [core for _, _, core in blobs]
        self._cores.pop(self._frame - AUTO_WINDOW, None)

    def model(self, felt_bgr: np.ndarray) -> Optional[ColourModel]:
        """The learned colour box (named `learned`), or None while the evidence is not clear. felt_bgr: the bare felt's
        colour: every ball in play (white, yellow, yellow-green, orange, cork) is lighter than its felt, while a
        figure sliding beside its rod, a hand or a shadow that moves need not be."""
        cores = [self._cores[frame][k] for frame, k in self._votes.moving_blobs() if frame in self._cores]
        if len(cores) < MOTION_MIN_VOTES:
            return None
        lab = _lab(np.array(cores))
        felt_light = _lab(np.asarray(felt_bgr, float)[None])[0, 0]
        lab = lab[lab[:, 0] >= felt_light + MOTION_LIGHTER]
        if len(lab) < MOTION_MIN_VOTES:
            return None
        # The commonest colour: the core with the most cores within MOTION_MAX_SPREAD of it in a and b; clear when it
        # has twice the cores of the commonest colour among the rest (as the prototypes' vote).
        near = np.hypot(lab[:, None, 1] - lab[None, :, 1], lab[:, None, 2] - lab[None, :, 2]) <= MOTION_MAX_SPREAD
        best = int(np.argmax(near.sum(axis=1)))
        agree = near[best]
        rest = near[~agree][:, ~agree]
        if np.count_nonzero(agree) < max(MOTION_MIN_VOTES, 2 * (rest.sum(axis=1).max() if len(rest) else 0)):
            return None
        a, b = np.median(lab[agree, 1]), np.median(lab[agree, 2])
        spread = np.hypot(lab[agree, 1] - a, lab[agree, 2] - b)
        # The box: the cores' spread of a and b, with room for the rim's blend with the felt; lightness from the
        # darkest cores down (shading), or from just above the felt's, to white.
        tol = float(np.clip(2.0 * np.percentile(spread, 90) + 6.0, MOTION_TOL[0], MOTION_TOL[1]))
        l_min = int(max(20.0, min(np.percentile(lab[agree, 0], 10) - 30.0, felt_light + 5.0)))
        return ColourModel("learned", l_min, 255, float(a), float(b), tol)


def _lab(bgr: np.ndarray) -> np.ndarray:
    """(N, 3) BGR to (N, 3) OpenCV 8-bit Lab, as floats."""
    return cv2.cvtColor(np.clip(bgr, 0, 255).astype(np.uint8)[None], cv2.COLOR_BGR2Lab)[0].astype(float)


MOTION_MIN_VOTES = 6  # moving ball-like blobs of one colour before it is taken
MOTION_MAX_SPREAD = 8.0  # Lab a/b levels between two cores of the same colour
MOTION_LIGHTER = 15.0  # Lab L levels a core is lighter than the felt, to be a ball's
MOTION_TOL = (10.0, 30.0)  # the learned box's half width in a and b (20 at least: 98 false detections per 1000 hidden frames on
# a render with the prototypes blinded, the box taking the red figures' lit edges)


class ColourLearner:
    """TrackerConfig.learn_after > 0: the pixels of the ball's core (0.6 radii) in its first confident
    detections, to re-centre the colour box on the ball seen."""

    def __init__(self, learn_after: int):
        self.learn_after = learn_after
        self.learned = False
        self._pixels: list[np.ndarray] = []

    def collect(self, lab: np.ndarray, roi, c: Candidate, radius: float) -> Optional[np.ndarray]:
        """Add this detection's core pixels (lab: the Lab pixels of roi); all the pixels collected once there are
        learn_after detections' worth, else None."""
        x0, y0 = roi[0], roi[1]
        r = 0.6 * radius
        u, v = c.u - x0, c.v - y0
        ys, xs = np.mgrid[0:lab.shape[0], 0:lab.shape[1]]
        core = (xs - u) ** 2 + (ys - v) ** 2 <= r * r
        pixels = lab[core]
        if len(pixels):
            self._pixels.append(pixels)
        if len(self._pixels) < self.learn_after:
            return None
        self.learned = True
        return np.concatenate(self._pixels)
