"""Checkerboard views drawn through a known lens, for testing calibrate_camera (and the benchmark's row
whose intrinsics come from it).

Each pixel's ray comes from the lens model (cv2.fisheye or cv2.undistortPoints, with the camera's own
coefficients) and is intersected with the board's plane, so the images are what that lens would film,
up to anti-aliasing (2x2 samples per pixel) and sensor noise. Boards are held at random poses that
reach the edges of the image, where a lens's k terms show.

ROS-free: numpy and OpenCV.
"""
from __future__ import annotations

import math

import cv2
import numpy as np

from foos_core.camera_model import CameraConfig

BACKGROUND, WHITE, BLACK = 110.0, 235.0, 25.0


def pixel_rays(camera: CameraConfig, samples: int = 2) -> np.ndarray:
    """(samples^2, H, W, 2) normalised rays (x / z, y / z; OpenCV camera frame) of sub-pixel points;
    NaN for rays the lens cannot form (beyond 90 degrees)."""
    k, d = camera.camera_matrix(), camera.dist_coeffs()
    offsets = (np.arange(samples) + 0.5) / samples - 0.5
    u, v = np.meshgrid(np.arange(camera.width, dtype=np.float64), np.arange(camera.height, dtype=np.float64))
    out = np.empty((samples * samples, camera.height, camera.width, 2))
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-8)
    for i, (du, dv) in enumerate((du, dv) for dv in offsets for du in offsets):
        points = np.stack([u + du, v + dv], axis=-1).reshape(-1, 1, 2)
        if camera.fisheye:
            rays = cv2.fisheye.undistortPoints(points, k, d, criteria=criteria).reshape(-1, 2)
            theta_d = np.linalg.norm((points.reshape(-1, 2) - k[:2, 2]) / np.diag(k)[:2], axis=1)
            rays[theta_d >= math.pi / 2] = np.nan
        else:
            rays = cv2.undistortPoints(points, k, d, criteria=criteria).reshape(-1, 2)
        out[i] = rays.reshape(camera.height, camera.width, 2)
    return out


def random_pose(rng: np.random.Generator, camera: CameraConfig, board_size: float, reach: float = 0.8):
    """(origin, x axis, y axis) of a board in the camera frame: its centre along a ray up to `reach` of the
    way to the image's edge in a random direction, at a distance where it spans about a third of the
    image height, tilted up to 40 degrees."""
    k = camera.camera_matrix()
    azimuth = rng.uniform(0, 2 * math.pi)
    edge = min(camera.width, camera.height) / 2 + abs(math.cos(azimuth)) * (camera.width - camera.height) / 2
    pixel = k[:2, 2] + rng.uniform(0, reach) * edge * np.array([math.cos(azimuth), math.sin(azimuth)])
    if camera.fisheye:
        ray = cv2.fisheye.undistortPoints(pixel.reshape(1, 1, 2), k, camera.dist_coeffs()).ravel()
    else:
        ray = cv2.undistortPoints(pixel.reshape(1, 1, 2), k, camera.dist_coeffs()).ravel()
    direction = np.array([ray[0], ray[1], 1.0])
    direction /= np.linalg.norm(direction)
    distance = board_size * k[1, 1] / (camera.height / 3)
    centre = direction * distance
    # Facing the camera, then tilted about a random in-plane axis and turned about its normal.
    normal = -direction
    x_axis = np.cross([0.0, 1.0, 0.0], normal)
    x_axis /= np.linalg.norm(x_axis)
    y_axis = np.cross(normal, x_axis)
    tilt_axis_angle, tilt, spin = rng.uniform(0, 2 * math.pi), math.radians(rng.uniform(10, 40)), rng.uniform(-0.5, 0.5)
    tilt_axis = math.cos(tilt_axis_angle) * x_axis + math.sin(tilt_axis_angle) * y_axis
    rotation = cv2.Rodrigues(tilt_axis * tilt)[0] @ cv2.Rodrigues(normal * spin)[0]
    x_axis, y_axis = rotation @ x_axis, rotation @ y_axis
    return centre, x_axis, y_axis


def draw_board(rays: np.ndarray, board: tuple[int, int], square: float, pose, noise: float = 1.5,
               rng: np.random.Generator | None = None) -> np.ndarray:
    """A grey uint8 image of a board with (cols, rows) inner corners, `square` m, at pose (centre, x axis,
    y axis in the camera frame), with a white border of one square; elsewhere a grey wall."""
    cols, rows = board
    centre, x_axis, y_axis = (np.asarray(v, float) for v in pose)
    normal = np.cross(x_axis, y_axis)
    # Inner corner (i, j) sits at origin + i * square * x + j * square * y; the centre is the board's middle.
    origin = centre - (cols - 1) / 2 * square * x_axis - (rows - 1) / 2 * square * y_axis
    ray3 = np.concatenate([rays, np.ones(rays.shape[:-1] + (1,))], axis=-1)
    facing = ray3 @ normal
    with np.errstate(divide="ignore", invalid="ignore"):
        t = (origin @ normal) / facing
        points = ray3 * t[..., None] - origin
        a, b = points @ x_axis / square, points @ y_axis / square
        on_board = (t > 0) & (a >= -2) & (a <= cols + 1) & (b >= -2) & (b <= rows + 1)
        squares = (a >= -1) & (a <= cols) & (b >= -1) & (b <= rows)
        dark = (np.floor(a) + np.floor(b)) % 2 == 0
    value = np.where(on_board, np.where(squares & dark, BLACK, WHITE), BACKGROUND)
    image = np.nan_to_num(value, nan=0.0).mean(axis=0)
    if noise > 0:
        image = image + (rng or np.random.default_rng()).normal(0.0, noise, image.shape)
    return np.clip(image + 0.5, 0, 255).astype(np.uint8)


def board_views(camera: CameraConfig, count: int, board: tuple[int, int] = (9, 6), square: float = 0.03,
                seed: int = 0) -> list[np.ndarray]:
    """`count` grey views of the board through `camera`'s lens, at random poses."""
    rng = np.random.default_rng(seed)
    rays = pixel_rays(camera)
    size = (max(board) + 1) * square
    return [draw_board(rays, board, square, random_pose(rng, camera, size), rng=rng) for _ in range(count)]
