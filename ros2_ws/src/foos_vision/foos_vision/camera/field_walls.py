"""The walls round the felt, where the felt's edge is not the field's: field_auto's last step.

- walls_round_felt: a felt that is not the table's shape may have a border of the playing surface round it
  (white on goal5's table) between it and a pair of walls; they are looked for where the table's shape puts them.
"""
from __future__ import annotations

from typing import Optional

import cv2
import numpy as np

from .field_lines import CORNER_SKIP, MIN_SUPPORT, SAMPLES_PER_SIDE, STEP_PX, robust_line
from .geometry import surface_homography

WALL_SEARCH = 1.0  # of the border's width: how far beyond where the table's shape puts a wall it is looked for
BORDER_SKIP_PX = 3.0  # the felt's own edge is this close to it
WALL_MIN_STEP = 4.0  # grey levels per px: a weaker step is not a wall's foot


def walls_round_felt(gray: np.ndarray, corners: np.ndarray, aspect: float, lens, half_width: float,
                      half_length: float) -> Optional[dict[int, tuple[np.ndarray, float, float]]]:
    """Where the felt is not the table's shape, a border of the playing surface (another colour: white on many
    tables) lies between it and a pair of walls. The felt's corners (undistorted px) taken as a rectangle of its own
    measured aspect put those walls where the table's shape says; each is looked for there as a straight step of
    grey level (the strongest across WALL_SEARCH of the border's width). Per side found: (line, support, RMS px);
    None unless both walls of the pair are found."""
    expected = half_length / half_width
    if aspect > expected:  # the felt is too narrow: the side walls (sides 2 and 4) lie beyond a border
        sides, felt_half = (1, 3), (half_length / aspect, half_length)
    else:  # too short: the end walls
        sides, felt_half = (0, 2), (half_width, half_width * aspect)
    to_image = np.linalg.inv(surface_homography(corners, *felt_half))
    blurred = cv2.GaussianBlur(gray.astype(np.float32), (0, 0), 1.0)
    table = np.array([(-1, -1), (1, -1), (1, 1), (-1, 1)], float)
    found = {}
    for i in sides:
        a, b = table[i], table[(i + 1) % 4]
        s = np.linspace(CORNER_SKIP, 1.0 - CORNER_SKIP, SAMPLES_PER_SIDE)[:, None]
        felt_edge = (a + s * (b - a)) * felt_half
        wall = (a + s * (b - a)) * (half_width, half_length)
        at_felt, at_wall = to_pixels(to_image, felt_edge), to_pixels(to_image, wall)
        outward = at_wall - at_felt
        border = np.linalg.norm(outward, axis=1, keepdims=True)
        outward = outward / np.maximum(border, 1e-9)
        # From just beyond the felt's edge to as far again beyond where the table's shape puts the wall: the felt's
        # measured aspect is only as good as the focal length the corners reveal.
        width = float(np.median(border))
        offsets = np.arange(-width + BORDER_SKIP_PX, WALL_SEARCH * width + 1e-9, STEP_PX)
        across = at_wall[:, None, :] + offsets[None, :, None] * outward[:, None, :]
        image = lens.distort(across.reshape(-1, 2)).reshape(across.shape).astype(np.float32)
        profiles = cv2.remap(blurred, image[..., 0], image[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
        gradient = np.gradient(profiles, STEP_PX, axis=1)
        peak = np.argmax(np.abs(gradient), axis=1)
        rows = np.arange(len(peak))
        strength = gradient[rows, peak]
        # A wall's foot is one step all along it: its sign is most samples' step's, and weak steps are none.
        keep = (np.sign(strength) == np.sign(np.median(strength))) & (np.abs(strength) >= WALL_MIN_STEP)
        points = (at_wall + offsets[peak][:, None] * outward)[keep]
        line, inliers = robust_line(points)
        if line is None or inliers.sum() < MIN_SUPPORT * SAMPLES_PER_SIDE:
            return None
        spread = float(np.sqrt(np.mean((points[inliers] @ line[:2] - line[2]) ** 2)))
        found[i] = (line, min(1.0, inliers.sum() / SAMPLES_PER_SIDE), spread)
    return found


def to_pixels(plane_to_image: np.ndarray, xy: np.ndarray) -> np.ndarray:
    return cv2.perspectiveTransform(np.asarray(xy, float).reshape(-1, 1, 2), plane_to_image).reshape(-1, 2)
