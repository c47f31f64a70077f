"""calibrate_camera on checkerboard views imaged through a known lens (pinhole + radial distortion)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from foos_core.camera_model import CameraConfig, load_intrinsics
from foos_sim.camera.boards import board_views
from foos_vision.camera.geometry import Lens

from .helpers import ros2_run

K = np.array([[520.0, 0, 319.5], [0, 520.0, 239.5], [0, 0, 1]])
DIST = np.array([-0.25, 0.07, 0, 0, 0])
SQUARE_PX = 40  # board image resolution: pixels per square
SQUARE_M = 0.03


def board_image(cols_sq=10, rows_sq=7):
    margin = SQUARE_PX
    img = np.full((rows_sq * SQUARE_PX + 2 * margin, cols_sq * SQUARE_PX + 2 * margin), 255, np.uint8)
    for r in range(rows_sq):
        for c in range(cols_sq):
            if (r + c) % 2 == 0:
                img[margin + r * SQUARE_PX:margin + (r + 1) * SQUARE_PX, margin + c * SQUARE_PX:margin + (c + 1) * SQUARE_PX] = 0
    return img, margin


def view(board, margin, rvec, tvec, size=(640, 480)):
    """The board seen by the camera: per output pixel, undistort, cast the ray, hit the board plane."""
    w, h = size
    u, v = np.meshgrid(np.arange(w, dtype=np.float32), np.arange(h, dtype=np.float32))
    rays = cv2.undistortPoints(np.stack([u.ravel(), v.ravel()], 1).reshape(-1, 1, 2), K, DIST).reshape(-1, 2)
    rays = np.c_[rays, np.ones(len(rays))]
    rotation, _ = cv2.Rodrigues(np.asarray(rvec, float))
    normal = rotation[:, 2]
    s = (normal @ tvec) / (rays @ normal)
    points = rays * s[:, None] - tvec
    local = points @ rotation  # board frame (x, y, ~0)
    map_x = (local[:, 0] / SQUARE_M * SQUARE_PX + margin - 0.5).reshape(h, w).astype(np.float32)
    map_y = (local[:, 1] / SQUARE_M * SQUARE_PX + margin - 0.5).reshape(h, w).astype(np.float32)
    return cv2.remap(board, map_x, map_y, cv2.INTER_LINEAR, borderValue=128)


@pytest.mark.timeout(120)
def test_calibrate_camera_recovers_the_lens(tmp_path):
    board, margin = board_image()
    rng = np.random.default_rng(1)
    for i in range(8):
        rvec = rng.normal(0, 0.35, 3)
        tvec = np.array([-0.15 + rng.uniform(-0.08, 0.08), -0.1 + rng.uniform(-0.05, 0.05), rng.uniform(0.45, 0.6)])
        cv2.imwrite(str(tmp_path / f"view{i}.png"), view(board, margin, rvec, tvec))
    out = tmp_path / "camera.yaml"
    result = ros2_run("calibrate_camera", str(tmp_path), "--board", "9x6", "--square", str(SQUARE_M), "--out", str(out))
    assert result.returncode == 0, result.stderr
    tree = yaml.safe_load(out.read_text())
    matrix = np.array(tree["camera_matrix"])
    assert abs(matrix[0, 0] - K[0, 0]) / K[0, 0] < 0.02
    assert abs(tree["dist_coeffs"][0] - DIST[0]) < 0.04
    assert tree["rms_reprojection_error_px"] < 0.5
    # The file is what track_video --intrinsics reads.
    assert load_intrinsics(out).width == 640


def test_calibrate_camera_without_a_board_says_so(tmp_path):
    cv2.imwrite(str(tmp_path / "blank.png"), np.full((100, 100, 3), 200, np.uint8))
    result = ros2_run("calibrate_camera", str(tmp_path / "blank.png"), "--out", str(tmp_path / "c.yaml"))
    assert result.returncode == 2
    assert result.stderr.count("\n") == 1 and "INNER corners" in result.stderr


# A wide fisheye (110 degrees of vertical field, OpenCV's equidistant model) and its boards, drawn by
# foos_sim.camera.boards through that exact lens.
FISHEYE = dict(width=640, height=480, fovy=110.0, model="fisheye", distortion=(0.06, -0.03, 0.012, -0.004))


@pytest.mark.timeout(120)
def test_calibrate_camera_fisheye_recovers_the_lens(tmp_path):
    camera = CameraConfig(**FISHEYE)
    for i, image in enumerate(board_views(camera, 12, board=(9, 6), square=SQUARE_M, seed=2)):
        cv2.imwrite(str(tmp_path / f"view{i:02d}.png"), image)
    out = tmp_path / "fisheye.yaml"
    result = ros2_run("calibrate_camera", str(tmp_path), "--board", "9x6", "--square", str(SQUARE_M), "--fisheye",
                      "--out", str(out))
    assert result.returncode == 0, result.stderr
    fitted = load_intrinsics(out)
    assert fitted.fisheye and yaml.safe_load(out.read_text())["rms_reprojection_error_px"] < 0.3
    truth = camera.camera_matrix()
    assert abs(fitted.camera_matrix[0, 0] - truth[0, 0]) / truth[0, 0] < 0.01
    assert np.allclose(fitted.camera_matrix[:2, 2], truth[:2, 2], atol=2.0)
    # The k terms trade off against each other, so the lens is judged by what it does: across the image,
    # out to 0.9 of the way to its corners (where few boards reach), the fitted lens puts every ray within a
    # pixel of the true one, most within a third of one.
    k = truth
    grid = np.stack(np.meshgrid(np.linspace(-0.9, 0.9, 15), np.linspace(-0.9, 0.9, 15)), -1).reshape(-1, 2)
    pixels = k[:2, 2] + grid * k[:2, 2]
    rays = Lens(camera.intrinsics()).undistort(pixels)
    moved = Lens(fitted).distort(rays)
    off = np.linalg.norm(moved - pixels, axis=1)
    assert np.max(off) < 1.0 and np.median(off) < 0.3, off
    assert np.allclose(fitted.dist_coeffs, camera.distortion, atol=0.03)
