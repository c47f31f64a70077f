"""calibrate_camera: camera intrinsics (OpenCV pinhole + distortion, or cv2.fisheye) from checkerboard
images or a video."""
from __future__ import annotations

import argparse
from pathlib import Path

import cv2
import numpy as np

from foos_core.camera_model import Intrinsics
from foos_core.command_line import run_cli

from .errors import VisionError
from .video_io import VideoReader

DESCRIPTION = """\
Compute the camera matrix and distortion coefficients from views of a printed checkerboard, as
cv2.calibrateCamera does, and write them as YAML for `track_video --intrinsics` / tracker_node.
Give image files, a directory of images, or a video (every --step-th frame is tried).
--board is the count of INNER corners (columns x rows), e.g. 9x6 for a 10x7-square board.

With --fisheye the lens is OpenCV's fisheye model (cv2.fisheye.calibrate: equidistant projection,
k1..k4), for wide lenses where the pinhole's k1, k2, p1, p2, k3 cannot follow the edges; the YAML then
says `model: fisheye`. Views that fill the corners of the image pin k down; a board only ever seen in
the middle leaves it loose.

Examples:
  calibrate_camera board_video.mp4 --board 9x6 --square 0.025 --out camera.yaml
  calibrate_camera shots/ --board 9x6 --square 0.03 --fisheye --out fisheye.yaml
"""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="calibrate_camera", description=DESCRIPTION,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("inputs", nargs="+", help="images, a directory of images, or one video")
    p.add_argument("--board", default="9x6", help="inner corners, columns x rows (default 9x6)")
    p.add_argument("--square", type=float, default=0.025, help="square edge in m (default 0.025)")
    p.add_argument("--out", required=True, help="intrinsics YAML to write")
    p.add_argument("--step", type=int, default=10, help="use every step-th video frame (default 10)")
    p.add_argument("--max-views", type=int, default=40, help="views used at most (default 40)")
    p.add_argument("--fisheye", action="store_true", help="fit OpenCV's fisheye model (k1..k4) instead of the pinhole one")
    return p


def _frames(inputs: list[str], step: int):
    paths: list[Path] = []
    for item in inputs:
        path = Path(item)
        if path.is_dir():
            paths += sorted(p for p in path.iterdir() if p.suffix.lower() in (".png", ".jpg", ".jpeg", ".bmp", ".tif"))
        elif not path.exists():
            raise VisionError(f"not found: {item}")
        else:
            paths.append(path)
    for path in paths:
        image = cv2.imread(str(path))
        if image is not None:
            yield str(path), image
            continue
        reader = VideoReader(str(path))
        for index, _, frame in reader.frames():
            if index % step == 0:
                yield f"{path}#{index}", frame
        reader.close()


def calibrate(args: argparse.Namespace) -> int:
    try:
        cols, rows = (int(v) for v in args.board.lower().split("x"))
    except ValueError:
        raise VisionError(f"--board `{args.board}` is not COLSxROWS, e.g. 9x6") from None
    if cols < 2 or rows < 2 or not args.square > 0:
        raise VisionError("--board needs at least 2x2 inner corners and --square a positive size")
    board = np.zeros((rows * cols, 3), np.float32)
    board[:, :2] = np.mgrid[0:cols, 0:rows].T.reshape(-1, 2) * args.square
    object_points, image_points, size = [], [], None
    tried = 0
    for name, frame in _frames(args.inputs, max(1, args.step)):
        tried += 1
        gray = cv2.cvtColor(frame, cv2.COLOR_BGR2GRAY)
        if size is not None and gray.shape[::-1] != size:
            raise VisionError(f"{name}: image size {gray.shape[::-1]} differs from the first one {size}")
        size = gray.shape[::-1]
        found, corners = cv2.findChessboardCorners(gray, (cols, rows), cv2.CALIB_CB_ADAPTIVE_THRESH | cv2.CALIB_CB_NORMALIZE_IMAGE)
        if not found:
            continue
        corners = cv2.cornerSubPix(gray, corners, (5, 5), (-1, -1),
                                   (cv2.TERM_CRITERIA_EPS | cv2.TERM_CRITERIA_MAX_ITER, 30, 1e-3))
        object_points.append(board)
        image_points.append(corners)
        if len(image_points) >= args.max_views:
            break
    if len(image_points) < 3:
        raise VisionError(f"the {args.board} board was found in {len(image_points)} of {tried} images; "
                          f"at least 3 views are needed (check --board: INNER corners)")
    if args.fisheye:
        rms, matrix, dist = _calibrate_fisheye(object_points, image_points, size)
    else:
        rms, matrix, dist, _, _ = cv2.calibrateCamera(object_points, image_points, size, None, None)
    if not (np.all(np.isfinite(matrix)) and np.all(np.isfinite(dist)) and np.isfinite(rms)):
        raise VisionError("the calibration did not converge (NaN); use more views, from several angles")
    Intrinsics(matrix, dist.ravel(), size[0], size[1], "fisheye" if args.fisheye else "pinhole").to_yaml(args.out, rms)
    print(f"calibrate_camera: {len(image_points)} views, RMS reprojection error {rms:.3f} px, "
          f"fx {matrix[0, 0]:.1f} px, k1 {dist.ravel()[0]:+.4f} -> {args.out}")
    return 0


def _fisheye_flag(name: str) -> int:
    # OpenCV 4 keeps the fisheye flags in cv2.fisheye; OpenCV 5 has one set of CALIB_ flags.
    return int(getattr(cv2.fisheye, name, None) or getattr(cv2, name))


def _calibrate_fisheye(object_points, image_points, size):
    flags = _fisheye_flag("CALIB_RECOMPUTE_EXTRINSIC") | _fisheye_flag("CALIB_FIX_SKEW")
    criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-9)
    objects = [p.reshape(1, -1, 3).astype(np.float64) for p in object_points]
    images = [p.reshape(1, -1, 2).astype(np.float64) for p in image_points]
    try:
        rms, matrix, dist, _, _ = cv2.fisheye.calibrate(objects, images, size, np.eye(3), np.zeros((4, 1)),
                                                        flags=flags, criteria=criteria)
    except cv2.error as error:
        message = str(error).strip().splitlines()[-1] if str(error).strip() else "cv2.error"
        raise VisionError(f"the fisheye calibration failed ({message}); use more views, from several angles") from None
    return rms, matrix, dist


def main(argv=None) -> None:
    run_cli(build_parser(), calibrate, argv)


if __name__ == "__main__":
    main()
