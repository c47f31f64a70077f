"""Straight lines through edge points, for field_auto and field_walls: robust fits, intersections, and the barrel
lens a set of sides reveals (a division model) where --intrinsics does not give it."""
from __future__ import annotations

import math
from typing import Optional

import numpy as np

SAMPLES_PER_SIDE = 96  # edge points looked for across a side's middle ...
CORNER_SKIP = 0.12  # ... this share of it left out at each end
STEP_PX = 0.5  # profile sampling across an edge
MIN_SUPPORT = 0.4  # of a side's samples on its line, at least
INLIER_PX = 1.5  # an edge point this close to its side's line (or 3 robust sigma) supports it
MAX_BEND = 0.6  # the strongest barrel bend (DivisionLens.strength) looked for: a wide fisheye's
STRAIGHTER = 0.7  # a bend is taken only where it leaves the sides' bow at most this share of a pinhole's


class NoIntersection(ValueError):
    """Two lines that do not meet."""


class DivisionLens:
    """A barrel lens not given by --intrinsics, as the felt's sides tell it: one-parameter division model about the
    image centre, p_u = c + (p_d - c) / (1 - strength r^2), r = |p_d - c| / the image's half diagonal. The same
    interface as geometry.Lens (points only)."""

    def __init__(self, strength: float, size: tuple[int, int]):
        self.strength = strength
        self.centre = np.array([size[0] / 2 - 0.5, size[1] / 2 - 0.5])
        self.scale = math.hypot(size[0], size[1]) / 2

    @classmethod
    def straightening(cls, sides: list[np.ndarray], size: tuple[int, int]) -> "DivisionLens":
        """The strength that makes the four sides' edge points straightest: the sum of their median distances from
        their lines, in pixels of the image (undistortion's stretch divided out). A bent lens's sides bow, most
        those far from the image's centre; a pinhole's are straight at strength 0."""
        def bow(strength: float) -> float:
            lens = cls(strength, size)
            total = 0.0
            for points in sides:
                if len(points) < 8:
                    continue
                undistorted = lens.undistort(points)
                keep = np.ones(len(points), bool)
                for _ in range(3):  # trimmed: a figure at the edge or a corner ramp's start is left out
                    line = fit_line(undistorted[keep])
                    distance = np.abs(undistorted @ line[:2] - line[2])
                    keep = distance <= max(INLIER_PX, 3.0 * float(np.median(distance[keep])))
                r2 = np.sum(((points - lens.centre) / lens.scale) ** 2, axis=1)
                total += float(np.median((distance * (1.0 - strength * r2))[keep]))
            return total

        grid = np.linspace(0.0, MAX_BEND, 31)
        values = [bow(g) for g in grid]
        best = int(np.argmin(values))
        low, high = grid[max(best - 1, 0)], grid[min(best + 1, len(grid) - 1)]
        for _ in range(20):  # golden-section search around the grid's best
            a, b = high - 0.618 * (high - low), low + 0.618 * (high - low)
            if bow(a) < bow(b):
                high = b
            else:
                low = a
        strength = (low + high) / 2
        # A bend that straightens the sides by less than STRAIGHTER is no lens's (a pinhole), only noise fitted.
        return cls(strength if bow(strength) < STRAIGHTER * values[0] else 0.0, size)

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        pixels = np.asarray(pixels, float).reshape(-1, 2)
        offset = (pixels - self.centre) / self.scale
        r2 = np.sum(offset ** 2, axis=1, keepdims=True)
        return self.centre + self.scale * offset / (1.0 - self.strength * r2)

    def distort(self, pixels: np.ndarray) -> np.ndarray:
        pixels = np.asarray(pixels, float).reshape(-1, 2)
        if self.strength == 0.0:
            return pixels
        offset = (pixels - self.centre) / self.scale
        r_u = np.linalg.norm(offset, axis=1, keepdims=True)
        # r_u = r_d / (1 - s r_d^2): s r_u r_d^2 + r_d - r_u = 0, the root near r_u.
        with np.errstate(invalid="ignore", divide="ignore"):
            r_d = np.where(r_u > 1e-12, (-1.0 + np.sqrt(1.0 + 4.0 * self.strength * r_u ** 2))
                           / (2.0 * self.strength * np.maximum(r_u, 1e-12)), r_u)
            offset = np.where(r_u > 1e-12, offset * r_d / np.maximum(r_u, 1e-12), offset)
        return self.centre + self.scale * offset


def robust_line(points: np.ndarray) -> tuple[Optional[np.ndarray], np.ndarray]:
    """(n, c) with n . p = c the line most of the points lie on (RANSAC, then total least squares on its inliers),
    and the inliers; (None, none) for fewer than 8 points."""
    keep = np.zeros(len(points), bool)
    if len(points) < 8:
        return None, keep
    rng = np.random.default_rng(0)
    best = -1
    for _ in range(200):
        i, j = rng.choice(len(points), 2, replace=False)
        d = points[j] - points[i]
        norm = np.linalg.norm(d)
        if norm < 1e-6:
            continue
        n = np.array([-d[1], d[0]]) / norm
        close = np.abs((points - points[i]) @ n) <= INLIER_PX
        if close.sum() > best:
            best, keep = int(close.sum()), close
    for _ in range(5):
        line = fit_line(points[keep])
        distance = np.abs(points @ line[:2] - line[2])
        spread = 1.4826 * np.median(distance[keep])
        new_keep = distance <= max(INLIER_PX, 3.0 * spread)
        if np.array_equal(new_keep, keep) or new_keep.sum() < 2:
            break
        keep = new_keep
    return fit_line(points[keep]), keep


def fit_line(points: np.ndarray) -> np.ndarray:
    mean = points.mean(axis=0)
    centred = points - mean
    _, vectors = np.linalg.eigh(centred.T @ centred)
    normal = vectors[:, 0]  # the direction of least spread
    return np.array([normal[0], normal[1], float(normal @ mean)])


def intersect(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    p = np.cross(np.array([l1[0], l1[1], -l1[2]]), np.array([l2[0], l2[1], -l2[2]]))
    if abs(p[2]) < 1e-12:
        raise NoIntersection("the lines are parallel")
    return p[:2] / p[2]
