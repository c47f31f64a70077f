"""The ball in one frame, with nothing else known: no tags, no corners, no colour, no frames before it.

What a ball is, in one picture of a table: the playing field is the largest stretch of one colour in the middle of
the image (the felt); the ball lies on it, is round, is as wide as the table's ball is in the felt's own scale
(field_size / ball diameter), and is lighter than the felt (every ball colour in play, white, yellow, yellow-green,
orange and cork, is lighter than green, blue or black felt, while the figures' heads and the shadows are darker or
the same). Lines on the felt are thin and are opened away at the ball's scale; a figure is taller than round.

StillBallFinder.find(bgr) returns the field it found (a convex outline and the ball's radius in pixels there) and
the ball candidates, best first. The real-footage bench (real_bench) scores it on single frames with labels; the
tracker does not use it (a video has motion and the tags' mapping, see motion_ball).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from foos_core.table_geometry import TableGeometry

WORK_WIDTH = 960  # px: frames are searched at this width (a 1080p ball of 16-40 px keeps 8-20 px)
FELT_CHROMA_TOL = 6.0  # Lab a/b levels around the felt's mode that are still felt
FELT_LIGHT_TOL = 45.0  # L levels: the felt's light falls off toward the walls
MIN_FELT_FILL = 0.5  # of the felt's closed stretch that is felt-coloured
MIN_FIELD_SHARE = 0.08  # of the image: less, and the felt found is not a table's playing field
AREA_RANGE = (0.35, 1.8)  # a candidate's area over the expected disc's (part hidden by a foot; blur grows it)
MIN_ROUNDNESS = 0.55  # minor over major axis of the blob's second moments (a line, a leg: far less)
MIN_LIGHTER = 12.0  # L levels the ball's core is above the felt around it


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
    radius: float  # px, sqrt(area / pi) of the blob, full frame
    area_ratio: float
    roundness: float
    lighter: float  # L levels above the local felt
    score: float


class StillBallFinder:
    def __init__(self, params_file: Optional[str] = None):
        self.table = TableGeometry.of(params_file)

    def find_field(self, bgr: np.ndarray) -> Optional[FeltField]:
        """The felt: the commonest colour of the image's middle, grown to the largest connected stretch of it."""
        scale = WORK_WIDTH / bgr.shape[1]
        small = cv2.resize(bgr, (WORK_WIDTH, round(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
        lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
        return self._felt(lab, scale)[0]

    def _felt(self, lab: np.ndarray, scale: float) -> tuple[Optional[FeltField], Optional[np.ndarray]]:
        h, w = lab.shape[:2]
        # The table is in the middle of the picture, and the felt is most of the table: its colour is the median of
        # the middle tenth of the image, refined on the pixels near it.
        middle = lab[2 * h // 5:3 * h // 5, 2 * w // 5:3 * w // 5].reshape(-1, 3).astype(np.float32)
        l0, a0, b0 = (float(x) for x in np.median(middle, axis=0))
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

    def find(self, bgr: np.ndarray) -> tuple[Optional[FeltField], list[StillCandidate]]:
        """The field and the ball candidates in it, best first (empty when no felt is found)."""
        scale = WORK_WIDTH / bgr.shape[1]
        small = cv2.resize(bgr, (WORK_WIDTH, round(bgr.shape[0] * scale)), interpolation=cv2.INTER_AREA)
        lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
        field, region = self._felt(lab, scale)
        if field is None:
            return None, []
        r = field.ball_radius_px * scale
        light = lab[..., 0].astype(np.float32)
        # The felt's light around each pixel: a median over a few ball widths takes no ball and no line.
        k = min(255, max(5, int(6 * r) | 1))
        step = max(1, int(r // 2))
        coarse = cv2.medianBlur(small[::step, ::step] if step > 1 else small, min(k // step | 1, 255))
        around = cv2.resize(cv2.cvtColor(coarse, cv2.COLOR_BGR2Lab)[..., 0], (light.shape[1], light.shape[0]),
                            interpolation=cv2.INTER_LINEAR).astype(np.float32)
        lighter = light - around
        mask = ((lighter >= MIN_LIGHTER) & (region > 0)).astype(np.uint8)
        # Lines and rods' highlights are thin: open them away at half the ball's width.
        ok = max(3, int(0.9 * r) | 1)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (ok, ok)))
        n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask, connectivity=8)
        expected = math.pi * r * r
        found = []
        for i in range(1, n):
            area = float(stats[i, cv2.CC_STAT_AREA])
            ratio = area / expected
            if not AREA_RANGE[0] <= ratio <= AREA_RANGE[1]:
                continue
            x, y, bw, bh = (int(stats[i, c]) for c in (cv2.CC_STAT_LEFT, cv2.CC_STAT_TOP, cv2.CC_STAT_WIDTH,
                                                        cv2.CC_STAT_HEIGHT))
            ys, xs = np.nonzero(labels[y:y + bh, x:x + bw] == i)
            if len(xs) < 5:
                continue
            ev = np.linalg.eigvalsh(np.cov(np.stack([xs, ys]).astype(float)))
            roundness = float(math.sqrt(max(ev[0], 1e-6) / max(ev[1], 1e-6)))
            if roundness < MIN_ROUNDNESS:
                continue
            contrast = float(np.median(lighter[ys + y, xs + x]))
            score = roundness * min(ratio, 1.0 / ratio) * min(1.0, contrast / (3 * MIN_LIGHTER))
            u, v = centroids[i]
            found.append(StillCandidate(float(u) / scale, float(v) / scale, math.sqrt(area / math.pi) / scale,
                                        ratio, roundness, contrast, score))
        found.sort(key=lambda c: -c.score)
        return field, found
