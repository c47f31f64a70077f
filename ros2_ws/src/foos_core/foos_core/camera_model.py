"""Camera description shared by the simulated camera (foos_sim.camera) and the tracker (foos_vision): a pinhole with OpenCV distortion, or a
fisheye (OpenCV's cv2.fisheye equidistant model).

A camera YAML gives the pose (position, look_at, up), the vertical field of view, the image size,
the frame rate, the lens `model` (`pinhole`, the default, or `fisheye`) and its `distortion`:
[k1, k2, p1, p2, k3] for a pinhole, [k1, k2, k3, k4] for a fisheye. Intrinsics YAMLs (written by
calibrate_camera) hold camera_matrix and dist_coeffs, the OpenCV names, and `model: fisheye` for a
fisheye lens.
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path

import cv2
import numpy as np
import yaml

from foos_core.yaml_files import read_mapping


class CameraConfigError(ValueError):
    """A camera configuration or intrinsics file that cannot describe a camera (the message is one line)."""


# The shipped cameras (camera_<name>.yaml) live with the table's parameter files.
CONFIG_DIR = Path(__file__).resolve().parent / "params"
LENS_MODELS = ("pinhole", "fisheye")
# The renderer films a pinhole; a fisheye image is remapped from a larger pinhole render of the same focal
# length (as sharp as the fisheye at the image centre, sharper off it). A wide fisheye's corners look
# more than 60 degrees off axis, where that render would grow without bound (tan theta), so it is at most
# this many times the output per axis, and rays beyond it render black, like a real fisheye's vignette.
FISHEYE_RENDER_SCALE = 1.5


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
    model: str = "pinhole"  # or "fisheye": r = f * theta_d, theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)

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

    @property
    def fisheye(self) -> bool:
        return self.model == "fisheye"

    def camera_matrix(self) -> np.ndarray:
        """OpenCV K (pixel centres at integer coordinates). fovy is the vertical field of view: of the
        pinhole, or of a fisheye's equidistant projection (r = f theta, before its k terms)."""
        half = math.radians(self.fovy) / 2.0
        f = (self.height / 2.0) / (half if self.fisheye else math.tan(half))
        return np.array([[f, 0.0, self.width / 2.0 - 0.5], [0.0, f, self.height / 2.0 - 0.5], [0.0, 0.0, 1.0]])

    def intrinsics(self) -> "Intrinsics":
        return Intrinsics(self.camera_matrix(), self.dist_coeffs(), self.width, self.height, self.model)

    def render_camera(self, max_scale: float = FISHEYE_RENDER_SCALE) -> "CameraConfig":
        """The ideal pinhole the scene is rendered with before the lens is applied: this camera without its
        distortion, or for a fisheye a pinhole of the same focal length, large enough for every ray of the
        fisheye image up to max_scale times its size per axis."""
        if not self.fisheye:
            return self.with_(distortion=())
        k = self.camera_matrix()
        w, h = self.width, self.height
        edge = np.linspace(0.0, 1.0, 64)
        border = np.concatenate([np.c_[edge * (w - 1), np.zeros(64)], np.c_[edge * (w - 1), np.full(64, h - 1.0)],
                                 np.c_[np.zeros(64), edge * (h - 1)], np.c_[np.full(64, w - 1.0), edge * (h - 1)]])
        rays = cv2.fisheye.undistortPoints(border.reshape(-1, 1, 2), k, self.dist_coeffs()).reshape(-1, 2)
        rays = rays[np.all(np.isfinite(rays), axis=1)]
        f = k[0, 0]
        reach = np.abs(rays).max(axis=0) if len(rays) else np.array([np.inf, np.inf])
        width = int(min(2 * math.ceil(f * reach[0] + 1), 2 * math.ceil(max_scale * w / 2)))
        height = int(min(2 * math.ceil(f * reach[1] + 1), 2 * math.ceil(max_scale * h / 2)))
        fovy = math.degrees(2 * math.atan((height / 2) / f))
        return replace(self, width=width, height=height, fovy=fovy, distortion=(), model="pinhole")

    def dist_coeffs(self) -> np.ndarray:
        d = np.zeros(4 if self.fisheye else 5)
        d[: len(self.distortion)] = self.distortion
        return d

    def rvec_tvec(self) -> tuple[np.ndarray, np.ndarray]:
        """OpenCV extrinsics (table -> camera with x right, y down, z forward)."""
        axes = self.axes()
        rotation = np.stack([axes[0], -axes[1], -axes[2]])
        rvec, _ = cv2.Rodrigues(rotation)
        tvec = -rotation @ np.asarray(self.position, float)
        return rvec.ravel(), tvec

    def project(self, points: np.ndarray, distorted: bool = True) -> np.ndarray:
        """Pixels (N, 2) of table-frame points (N, 3), through the lens model when distorted."""
        rvec, tvec = self.rvec_tvec()
        if distorted and self.fisheye:
            pixels, _ = cv2.fisheye.projectPoints(np.asarray(points, float).reshape(-1, 1, 3), rvec, tvec,
                                                  self.camera_matrix(), self.dist_coeffs())
            return pixels.reshape(-1, 2)
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
    tree = read_mapping(candidate, "camera config", CameraConfigError)
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
            elif key == "model":
                values[key] = str(value)
                if values[key] not in LENS_MODELS:
                    raise ValueError(f"`model` is one of {', '.join(LENS_MODELS)}, not `{value}`")
            else:
                values[key] = str(value)
        config = CameraConfig(**values)
    except (TypeError, ValueError) as error:
        raise CameraConfigError(f"{candidate}: {error}") from None
    if config.fisheye and len(config.distortion) > 4:
        raise CameraConfigError(f"{candidate}: a fisheye lens has 4 coefficients k1..k4, not {len(config.distortion)}")
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
    model: str = "pinhole"  # or "fisheye" (cv2.fisheye, dist_coeffs = k1..k4)

    @property
    def fisheye(self) -> bool:
        return self.model == "fisheye"

    def to_yaml(self, path: str | Path, rms: float | None = None) -> None:
        tree = {
            "model": self.model,
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
        if isinstance(tree.get("intrinsics"), dict):
            tree = tree["intrinsics"]  # render_video's OUT.camera.yaml carries them in this block
        matrix = np.asarray(tree["camera_matrix"], float).reshape(3, 3)
        dist = np.asarray(tree.get("dist_coeffs", []), float).ravel()
        width, height = int(tree["image_width"]), int(tree["image_height"])
        model = str(tree.get("model", "pinhole"))
    except (yaml.YAMLError, KeyError, TypeError, ValueError) as error:
        raise CameraConfigError(
            f"{path}: intrinsics need image_width, image_height, camera_matrix (3x3) and dist_coeffs ({error})"
        ) from None
    if not np.all(np.isfinite(matrix)) or not np.all(np.isfinite(dist)):
        raise CameraConfigError(f"{path}: intrinsics contain NaN or infinite values")
    if model not in LENS_MODELS:
        raise CameraConfigError(f"{path}: `model` is one of {', '.join(LENS_MODELS)}, not `{model}`")
    if model == "fisheye" and len(dist) != 4:
        raise CameraConfigError(f"{path}: a fisheye lens needs 4 dist_coeffs (k1..k4), not {len(dist)}")
    return Intrinsics(matrix, dist, width, height, model)
