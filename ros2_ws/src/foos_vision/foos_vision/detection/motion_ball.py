"""The ball where it moved: a background model of the static table, and the ball's learned colour against it.

A camera over a table sees the same felt, walls and lines frame after frame; what changes is the ball, the figures and
the hands. The background is a running mean of the field's box at half resolution (MotionMap.look takes in the frame
before once it was searched, so a frame is compared with the frames before it). Each pixel of a frame is, where the ball passed
during the exposure, a share alpha of the ball's colour B and the rest background F (P = alpha B + (1 - alpha) F, as
for a streak, streaks.py), whatever the ball did: rolled, streaked, half under a foot. So the change P - F points
along B - F, with a length alpha |B - F|. B is the ball's colour learned online from the whole balls the tracker saw
(BallSearch.ball_colour): a colour preset only starts it. A figure or a hand that moved changes the pixels along its
own colour's direction, a flicker of the lights along F's: neither is a share of the ball. The pixels whose change is
a share of the ball (ALPHA_RANGE, off that direction by little) make blobs; a blob is the ball when its shares add up
to about a disc of the ball's size there (a streak's shares add up to one disc too) and it is as wide as one across.

This finds a ball that the colour box misses: streaked, dimmed in a goal mouth, half under a foot, where a running
track expects it (BallSearch.moved_near). It starts no track: searched over the whole field with no track running, it
found nothing on goal5 in 72 frames and cost 15 % of the throughput.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable, Optional

import cv2
import numpy as np

from .components import components_with_stats
from .detector import Candidate

SCALE = 0.5  # the background is kept at half resolution: a ball of 8 px radius keeps 4
LEARN_RATE = 0.05  # per frame: a ball that rests 20 frames becomes table, a passing one does not
ALPHA_RANGE = (0.25, 1.4)  # a pixel's share of the ball that seeds a blob: below, noise and compression; above, not
# the ball's colour
FAINT_ALPHA = 0.1  # around a blob's seeds, fainter shares count too (a streak's ends, a blurred rim)
OFF_LINE = 12.0  # BGR levels off the background-to-ball line still a share, plus OFF_SLOPE of the share's length (shade)
SHARES_RANGE = (0.2, 1.5)  # a blob's shares over a disc: a fifth of a ball (under a foot) to one ball (they add up to
# one disc whatever it did; more is something else, a red figure come to rest in a new pose for an orange ball)
WIDTH_RANGE = (0.5, 1.6)  # the blob's spread across its long axis over a disc's (r / 2)
BOX_MARGIN = 32  # px around the field's box kept in the background
CHANGE_MIN = 30.0  # BGR levels (Euclidean) a pixel changes by, against the background, to be something that moved
MOVED_AREA, MOVED_ROUNDNESS = (0.5, 1.6), 0.6  # a moving blob of any colour that may be the ball: about a disc, round
CORE = 0.6  # radii: the core of a moving blob, whose mean colour is the ball's
MIN_CONTRAST = 25.0  # BGR levels between the ball's colour and the background: less, and no share can be told
OFF_SLOPE = 0.4  # the ball's own shading and its blend with what is beside it turn its change off the line


@dataclass
class MotionBlob:
    u: float
    v: float
    shares: float  # the blob's shares over a disc of the ball's radius there
    width: float  # spread across over a disc's
    roundness: float

    def candidate(self) -> Candidate:
        """As the tracker's candidate: its shares for the area, never a whole ball (fill 0: see solid)."""
        return Candidate(self.u, self.v, self.shares, self.roundness, min(self.shares, 1.0) * self.roundness,
                         spill=0.0, fill=0.0)


class MotionMap:
    def __init__(self):
        self._background: Optional[np.ndarray] = None
        self._roi: Optional[tuple[int, int, int, int]] = None
        self._frame: Optional[np.ndarray] = None  # uint8, this frame's box at SCALE (written into one buffer)
        self._region: Optional[np.ndarray] = None  # where the ball may be, at the background's resolution
        self._region_of: Optional[np.ndarray] = None  # the full-frame region it was made of

    def look(self, bgr: np.ndarray, roi: tuple[int, int, int, int], region: Optional[np.ndarray] = None) -> None:
        """The frame before becomes part of the background (it has been searched), and this is the frame now: the
        field box at the background's resolution (a new box starts the background again); region: full-frame uint8,
        non-zero where the ball may be (the field)."""
        self._remember()
        h, w = bgr.shape[:2]
        if self._roi is None or not _inside(roi, self._roi) or self._roi[2] > w or self._roi[3] > h:
            # The tags' refits move the field's box by a pixel or two: a margin keeps the background through them.
            x0, y0, x1, y1 = roi
            self._roi = (max(0, x0 - BOX_MARGIN), max(0, y0 - BOX_MARGIN), min(w, x1 + BOX_MARGIN), min(h, y1 + BOX_MARGIN))
            self._background, self._region = None, None
        x0, y0, x1, y1 = self._roi
        if x1 - x0 < 4 or y1 - y0 < 4:
            self._frame = None
            return
        # Kept in uint8 (accumulateWeighted takes it so): the float copy is made only where a search reads it.
        self._frame = cv2.resize(bgr[y0:y1, x0:x1], None, dst=self._frame, fx=SCALE, fy=SCALE,
                                 interpolation=cv2.INTER_AREA)
        if region is not None and (self._region is None or self._region_of is not region):
            self._region = cv2.resize(region[y0:y1, x0:x1], (self._frame.shape[1], self._frame.shape[0]),
                                      interpolation=cv2.INTER_NEAREST)
            self._region_of = region

    def _remember(self) -> None:
        if self._frame is None:
            return
        if self._background is None:
            self._background = self._frame.astype(np.float32)
        else:
            cv2.accumulateWeighted(self._frame, self._background, LEARN_RATE)

    def moved(self, radius_at: Callable[[float, float], float]) -> list[tuple[float, float, np.ndarray]]:
        """Round, ball-sized blobs of pixels that changed, whatever their colour: (u, v, the mean BGR of the frame in
        their core). What the ball's colour is learned from when no colour prototype fits it (ball_colour)."""
        if self._frame is None or self._background is None:
            return []
        frame = self._frame.astype(np.float32)
        change = frame - self._background
        moved = cv2.transform(change * change, np.ones((1, 3), np.float32)) >= CHANGE_MIN ** 2
        if self._region is not None:
            moved &= self._region > 0
        n, labels, stats, centroids = components_with_stats(moved.astype(np.uint8))
        x0, y0 = self._roi[0], self._roi[1]
        found = []
        for i in range(1, n):
            area = float(stats[i, cv2.CC_STAT_AREA])
            cu, cv_ = centroids[i]
            u, v = x0 + (cu + 0.5) / SCALE - 0.5, y0 + (cv_ + 0.5) / SCALE - 0.5
            r = radius_at(u, v) * SCALE
            if not MOVED_AREA[0] <= area / (math.pi * r * r) <= MOVED_AREA[1]:
                continue
            sx, sy, sw, sh = (int(stats[i, c]) for c in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                                          cv2.CC_STAT_HEIGHT))
            ys, xs = np.nonzero(labels[sy:sy + sh, sx:sx + sw] == i)
            ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(float)))
            if math.sqrt(max(ev[0], 1e-6) / max(ev[1], 1e-6)) < MOVED_ROUNDNESS:
                continue
            core = (xs + sx - cu) ** 2 + (ys + sy - cv_) ** 2 <= (CORE * r) ** 2
            if np.count_nonzero(core) < 3:
                continue
            found.append((u, v, frame[ys[core] + sy, xs[core] + sx].mean(axis=0)))
        return found

    def blobs(self, ball_bgr: np.ndarray, radius_at: Callable[[float, float], float],
              centre: Optional[np.ndarray] = None, reach: float = math.inf,
              felt_bgr: Optional[np.ndarray] = None) -> list[MotionBlob]:
        """Blobs of the ball's shares in this frame, within reach px of centre (full-frame pixels) when given, best
        first. felt_bgr: the bare felt's colour; given, a blob's seeds must be shares of the ball over the felt too (a
        figure that moved off the felt leaves felt where the background has the figure: a change toward the ball's
        colour from the figure's, but no ball)."""
        if self._frame is None or self._background is None:
            return []
        x0, y0, x1, y1 = self._roi
        h, w = self._frame.shape[:2]
        bx0, by0, bx1, by1 = 0, 0, w, h
        if centre is not None and math.isfinite(reach):
            bx0, by0 = max(0, int((centre[0] - x0 - reach) * SCALE)), max(0, int((centre[1] - y0 - reach) * SCALE))
            bx1, by1 = min(w, int((centre[0] - x0 + reach) * SCALE) + 2), min(h, int((centre[1] - y0 + reach) * SCALE) + 2)
            if bx1 - bx0 < 3 or by1 - by0 < 3:
                return []
        frame = self._frame[by0:by1, bx0:bx1].astype(np.float32)
        background = self._background[by0:by1, bx0:bx1]
        # Per pixel, with c = P - F and e = B - F: alpha = c.e / e.e, and off the line |c|^2 - alpha^2 e.e (channel sums
        # by cv2.transform: four times faster than numpy's on a 1080p field).
        ones = np.ones((1, 3), np.float32)
        change = frame - background
        towards = ball_bgr.astype(np.float32)[None, None, :] - background
        length2 = cv2.transform(towards * towards, ones)
        alpha = cv2.transform(change * towards, ones) / np.maximum(length2, 1e-3)
        off2 = np.maximum(cv2.transform(change * change, ones) - alpha * alpha * length2, 0.0)
        allowed = OFF_LINE + OFF_SLOPE * np.maximum(alpha, 0.0) * np.sqrt(length2)
        like_ball = (length2 >= MIN_CONTRAST ** 2) & (alpha <= ALPHA_RANGE[1]) & (off2 <= allowed * allowed)
        if self._region is not None:
            like_ball &= self._region[by0:by1, bx0:bx1] > 0
        faint = like_ball & (alpha >= FAINT_ALPHA)
        share = faint & (alpha >= ALPHA_RANGE[0])
        if felt_bgr is not None:
            felt = felt_bgr.astype(np.float32)
            over_felt = ball_bgr.astype(np.float32) - felt
            over_felt_alpha = (cv2.transform(frame, over_felt[None, :]) - float(felt @ over_felt)) / max(
                float(over_felt @ over_felt), 1e-3)
            share &= over_felt_alpha >= ALPHA_RANGE[0]
        n, labels, stats, centroids = components_with_stats(share.astype(np.uint8))
        found = []
        for i in range(1, n):
            if stats[i, cv2.CC_STAT_AREA] < 3:
                continue
            r = radius_at(x0 + (bx0 + centroids[i][0] + 0.5) / SCALE - 0.5,
                          y0 + (by0 + centroids[i][1] + 0.5) / SCALE - 0.5) * SCALE
            # The blob's own pixels and the faint shares around it (a streak's ends, a blurred rim): all of its shares.
            pad = int(math.ceil(0.5 * r)) + 1
            sx, sy = max(0, int(stats[i, cv2.CC_STAT_LEFT]) - pad), max(0, int(stats[i, cv2.CC_STAT_TOP]) - pad)
            ex = min(share.shape[1], int(stats[i, cv2.CC_STAT_LEFT] + stats[i, cv2.CC_STAT_WIDTH]) + pad)
            ey = min(share.shape[0], int(stats[i, cv2.CC_STAT_TOP] + stats[i, cv2.CC_STAT_HEIGHT]) + pad)
            grown = cv2.dilate((labels[sy:ey, sx:ex] == i).astype(np.uint8),
                               cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * pad + 1, 2 * pad + 1)))
            ys, xs = np.nonzero(grown & faint[sy:ey, sx:ex])
            weights = np.clip(alpha[ys + sy, xs + sx], 0.0, 1.0)
            total = float(weights.sum())
            cu = float(np.dot(xs + sx, weights)) / total  # np.dot: see streaks._blobs
            cv_ = float(np.dot(ys + sy, weights)) / total
            u, v = x0 + (bx0 + cu + 0.5) / SCALE - 0.5, y0 + (by0 + cv_ + 0.5) / SCALE - 0.5
            if centre is not None and math.hypot(u - centre[0], v - centre[1]) > reach:
                continue
            shares = total / (math.pi * r * r)
            if not SHARES_RANGE[0] <= shares <= SHARES_RANGE[1]:
                continue
            if len(xs) >= 3:
                d = np.stack([xs + sx - cu, ys + sy - cv_])
                cov = (d * weights) @ d.T / total
                ev = np.linalg.eigvalsh(cov)
            else:
                ev = np.array([r * r / 4, r * r / 4])
            width = math.sqrt(max(ev[0], 1e-6)) / (r / 2)
            if not WIDTH_RANGE[0] <= width <= WIDTH_RANGE[1]:
                continue
            found.append(MotionBlob(u, v, shares, width, float(math.sqrt(max(ev[0], 1e-6) / max(ev[1], 1e-6)))))
        if centre is not None:
            found.sort(key=lambda b: math.hypot(b.u - centre[0], b.v - centre[1]))
        else:
            found.sort(key=lambda b: -min(b.shares, 1.0 / b.shares) * b.roundness)
        return found


def _inside(inner: tuple[int, int, int, int], outer: tuple[int, int, int, int]) -> bool:
    return inner[0] >= outer[0] and inner[1] >= outer[1] and inner[2] <= outer[2] and inner[3] <= outer[3]
