"""The simulated camera in the loop: sim_node's images of the table, each of the state it shows.

A LiveCamera films the simulation's own qpos with the same scene, tags and lens as render_video, so
tracker_node, with its default parameters (the shipped tags, foos_core.markers), tracks the simulated table
as it would a real one. What the camera is (pose, field of view, lens) comes from a camera config
(foos_core.camera_model: `overhead` by default); its rate and image size are sim_node's parameters.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from foos_core.camera_model import Intrinsics, load_camera
from foos_core.markers import load_markers

from ..model_builder import build_mjcf
from .errors import RenderError
from .render import RenderOptions, SceneRenderer
from .scene import BALL_COLOURS

MIN_SIDE = 16  # px: the smallest image the renderer makes (camera_model's own rule)
MAX_RATE = 1000.0  # Hz: more is no camera


@dataclass(frozen=True)
class LiveCameraConfig:
    rate: float  # Hz, frames per simulated second
    width: int = 640
    height: int = 480
    camera: str = "overhead"  # a shipped camera's name or a camera YAML
    ball_colour: str = "white"
    noise: float = 1.5  # sensor noise, std in 8-bit levels
    shadows: bool = False  # a third of the cost on a software renderer; the tracker does not need them
    seed: int = 0

    def validate(self) -> None:
        if not (math.isfinite(self.rate) and 0 < self.rate <= MAX_RATE):
            raise RenderError(f"camera_rate must be in (0, {MAX_RATE:g}] Hz, got {self.rate}")
        if self.width < MIN_SIDE or self.height < MIN_SIDE:
            raise RenderError(f"camera_width and camera_height must be at least {MIN_SIDE}, got {self.width}x{self.height}")
        if self.ball_colour not in BALL_COLOURS:
            raise RenderError(f"camera ball colour must be one of {', '.join(BALL_COLOURS)}, got '{self.ball_colour}'")
        if not (math.isfinite(self.noise) and self.noise >= 0):
            raise RenderError(f"camera noise must be zero or positive, got {self.noise}")


def ros_distortion_model(intrinsics: Intrinsics) -> str:
    """sensor_msgs/CameraInfo's name of the lens model: plumb_bob (OpenCV k1, k2, p1, p2, k3) or equidistant
    (cv2.fisheye k1..k4)."""
    return "equidistant" if intrinsics.fisheye else "plumb_bob"


class LiveCamera:
    """Frames of a TableSimulation's state (its qpos), as BGR images of the configured size."""

    def __init__(self, config: LiveCameraConfig, params_file: Optional[str | Path] = None):
        config.validate()
        self.config = config
        self.camera = load_camera(config.camera).with_(width=int(config.width), height=int(config.height),
                                                        fps=float(config.rate))
        self.intrinsics = self.camera.intrinsics()  # what /camera/camera_info says of the images
        options = RenderOptions(camera=self.camera, ball_colour=BALL_COLOURS[config.ball_colour], noise=config.noise,
                                shadows=config.shadows, seed=config.seed)
        self._renderer = SceneRenderer(build_mjcf(params_file), load_markers(), options)

    def capture(self, qpos: np.ndarray) -> np.ndarray:
        """The image (H, W, 3) uint8 BGR of the table posed at qpos (the simulation's own layout)."""
        renderer = self._renderer
        return renderer.finish([renderer.render_rgb(qpos)])

    def close(self) -> None:
        self._renderer.close()
