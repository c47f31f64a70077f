"""Pinhole camera description shared by the renderer and the tracker.

A camera YAML gives the pose (position, look_at, up), the vertical field of view, the image size,
the frame rate and optional OpenCV distortion [k1, k2, p1, p2, k3]. `intrinsics_file` YAMLs (written
by calibrate_camera) hold camera_matrix and dist_coeffs, the OpenCV names.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import yaml

from .errors import CameraConfigError

CONFIG_DIR = Path(__file__).resolve().parent / "config"


@dataclass(frozen=True)
class CameraConfig:
    name: str = "overhead"
    width: int = 640
    height: int = 480
    fps: float = 120.0
    position: tuple[float, float, float] = (0.0, 0.0, 1.9)
    look_at: tuple[float, float, float] = (0.0, 0.0, 0.0)
    up: tuple[float, float, float] = (-1.0, 0.0, 0.0)
    fovy: float = 45.0
    distortion: tuple[float, ...] = field(default_factory=tuple)

    def with_(self, **changes) -> "CameraConfig":
        return replace(self, **{k: v for k, v in changes.items() if v is not None})

    # --- geometry --------------------------------------------------------------------------------
    def axes(self) -> np.ndarray:
        """Rows: camera x (image right), y (image up), z (backwards, MuJoCo's convention) in the table frame."""
        eye, target, up = (np.asarray(v, float) for v in (self.position, self.look_at, self.up))
        z = eye - target
        z /= np.linalg.norm(z)
        x = np.cross(up, z)
        if np.linalg.norm(x) < 1e-9:
            raise CameraConfigError(f"camera `{self.name}`: `up` is parallel to the viewing direction")
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        return np.stack([x, y, z])

    def camera_matrix(self) -> np.ndarray:
        """OpenCV K for the ideal pinhole (pixel centres at integer coordinates)."""
        f = (self.height / 2.0) / math.tan(math.radians(self.fovy) / 2.0)
        return np.array([[f, 0.0, self.width / 2.0 - 0.5], [0.0, f, self.height / 2.0 - 0.5], [0.0, 0.0, 1.0]])

    def dist_coeffs(self) -> np.ndarray:
        d = np.zeros(5)
        d[: len(self.distortion)] = self.distortion
        return d

    def rvec_tvec(self) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV extrinsics (table -> camera with x right, y down, z forward)."""
        axes = self.axes()
        rotation = np.stack([axes[0], -axes[1], -axes[2]])
        import cv2

        rvec, _ = cv2.Rodrigues(rotation)
        tvec = -rotation @ np.asarray(self.position, float)
        return rvec.ravel(), tvec

    def project(self, points: np.ndarray, distorted: bool = True) -> np.ndarray:
        """Pixels (N, 2) of table-frame points (N, 3), through the lens model when distorted."""
        import cv2

        rvec, tvec = self.rvec_tvec()
        dist = self.dist_coeffs() if distorted else np.zeros(5)
        pixels, _ = cv2.projectPoints(np.asarray(points, float).reshape(-1, 1, 3), rvec, tvec, self.camera_matrix(), dist)
        return pixels.reshape(-1, 2)

    def depth(self, points: np.ndarray) -> np.ndarray:
        """Distance along the optical axis of table-frame points."""
        axes = self.axes()
        return (np.asarray(points, float).reshape(-1, 3) - np.asarray(self.position)) @ (-axes[2])


def load_camera(path: str | Path | None) -> CameraConfig:
    """A camera config from YAML; a bare name (`overhead`, `oblique`) picks a shipped one."""
    if path is None:
        path = "overhead"
    candidate = Path(path)
    if not candidate.suffix and not candidate.exists():
        candidate = CONFIG_DIR / f"camera_{path}.yaml"
    if not candidate.is_file():
        raise CameraConfigError(f"camera config not found: {path} (give a YAML file or one of: overhead, oblique)")
    try:
        tree = yaml.safe_load(candidate.read_text()) or {}
    except yaml.YAMLError as error:
        raise CameraConfigError(f"{candidate}: not valid YAML ({error})".replace("\n", " ")) from None
    if not isinstance(tree, dict):
        raise CameraConfigError(f"{candidate}: a camera config is a YAML mapping")
    known = set(CameraConfig.__dataclass_fields__)
    unknown = set(tree) - known
    if unknown:
        raise CameraConfigError(f"{candidate}: unknown keys {sorted(unknown)} (known: {sorted(known)})")
    try:
        values = {}
        for key, value in tree.items():
            if key in ("position", "look_at", "up"):
                values[key] = tuple(float(v) for v in value)
                if len(values[key]) != 3:
                    raise ValueError(f"`{key}` needs 3 numbers")
            elif key == "distortion":
                values[key] = tuple(float(v) for v in (value or []))
            elif key in ("width", "height"):
                values[key] = int(value)
            elif key in ("fps", "fovy"):
                values[key] = float(value)
            else:
                values[key] = str(value)
        config = CameraConfig(**values)
    except (TypeError, ValueError) as error:
        raise CameraConfigError(f"{candidate}: {error}") from None
    if config.width < 16 or config.height < 16 or not (0 < config.fovy < 170) or config.fps <= 0:
        raise CameraConfigError(f"{candidate}: width/height >= 16, 0 < fovy < 170 and fps > 0 are required")
    config.axes()
    return config


@dataclass(frozen=True)
class Intrinsics:
    """OpenCV camera matrix and distortion coefficients, for the image size they were measured at."""

    camera_matrix: np.ndarray
    dist_coeffs: np.ndarray
    width: int
    height: int

    def to_yaml(self, path: str | Path, rms: float | None = None) -> None:
        tree = {
            "image_width": int(self.width),
            "image_height": int(self.height),
            "camera_matrix": self.camera_matrix.round(6).tolist(),
            "dist_coeffs": [float(v) for v in np.asarray(self.dist_coeffs).ravel()],
        }
        if rms is not None:
            tree["rms_reprojection_error_px"] = float(rms)
        Path(path).write_text(yaml.safe_dump(tree, sort_keys=False))


def load_intrinsics(path: str | Path) -> Intrinsics:
    path = Path(path)
    if not path.is_file():
        raise CameraConfigError(f"intrinsics file not found: {path}")
    try:
        tree = yaml.safe_load(path.read_text()) or {}
        matrix = np.asarray(tree["camera_matrix"], float).reshape(3, 3)
        dist = np.asarray(tree.get("dist_coeffs", []), float).ravel()
        width, height = int(tree["image_width"]), int(tree["image_height"])
    except (yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        raise CameraConfigError(
            f"{path}: intrinsics need image_width, image_height, camera_matrix (3x3) and dist_coeffs ({error})"
        ) from None
    if not np.all(np.isfinite(matrix)) or not np.all(np.isfinite(dist)):
        raise CameraConfigError(f"{path}: intrinsics contain NaN or infinite values")
    return Intrinsics(matrix, dist, width, height)
