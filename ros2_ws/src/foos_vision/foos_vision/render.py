"""The synthetic camera: renders a simulated (or recorded) rollout to an mp4 plus its ground truth.

Frame k is exposed around t_k = k / fps; its ground truth is the ball centre at t_k. With motion blur,
`subframes` renders spread over `exposure` of the frame interval, centred on t_k, are averaged, and the
ball's visible share is that at t_k times the share of the sub-frames it is in sight in (not picked up).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Iterator, Optional

import cv2
import mujoco
import numpy as np

from foos_core.names import BALL_JOINT, JOINT_NAMES

from .camera import CameraConfig
from .hands import AWAY_Z, HAND_BODY, HandPose
from .markers import MarkerLayout
from .scene import (
    BALL_COLOURS,
    CAMERA_NAME,
    build_scene_model,
    hide_cover,
    set_ball_colour,
    set_lighting,
    set_rod_finish,
    set_team_colour,
)

HIDDEN_Z = -2.0  # where a ball "picked up" by a hand is put for rendering: below the room floor


@dataclass
class RenderOptions:
    camera: CameraConfig
    ball_colour: tuple[float, float, float] = BALL_COLOURS["white"]
    subframes: int = 1  # > 1: motion blur by sub-frame averaging
    exposure: float = 0.5  # fraction of the frame interval the shutter is open (motion blur only)
    noise: float = 1.5  # sensor noise, std in 8-bit levels
    lighting: float = 1.0  # scale of the scene lights
    visibility: bool = False  # also measure the visible fraction of the ball (a segmentation render per frame)
    home_colour: Optional[tuple[float, float, float]] = None  # the figures' RGB; None: foos_sim's red
    away_colour: Optional[tuple[float, float, float]] = None  # None: foos_sim's blue
    hands: bool = False  # the scene has a player's hand (foos_vision.hands), posed per frame by render_frames' hand_at
    seed: int = 0


@dataclass
class FrameTruth:
    t: float
    position: np.ndarray  # (3,), NaN when the ball is out of sight on purpose (picked up)
    velocity: np.ndarray
    visible: float  # fraction of the ball's disc that is visible; NaN when not measured
    joints: np.ndarray = field(default_factory=lambda: np.zeros(0))  # the 16 rod joints (JOINT_NAMES order) at t


class DistortionMap:
    """Warps an ideal pinhole render (camera.render_camera()) into the image the lens makes: OpenCV
    distortion coefficients, or a cv2.fisheye lens. Each image pixel looks up where its ray meets the ideal
    render; rays outside it (or beyond 90 degrees off axis) are black."""

    def __init__(self, camera: CameraConfig):
        k, d = camera.camera_matrix(), camera.dist_coeffs()
        ideal_camera = camera.render_camera()
        u, v = np.meshgrid(np.arange(camera.width, dtype=np.float32), np.arange(camera.height, dtype=np.float32))
        distorted = np.stack([u.ravel(), v.ravel()], axis=1).reshape(-1, 1, 2)
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 40, 1e-4)
        if camera.fisheye:
            rays = cv2.fisheye.undistortPoints(distorted, k, d, criteria=criteria).reshape(-1, 2)
            # Where the lens polynomial stops rising, undistortion returns rays from behind the camera.
            theta_d = np.linalg.norm((distorted.reshape(-1, 2) - k[:2, 2]) / np.diag(k)[:2], axis=1)
            back = ~np.all(np.isfinite(rays), axis=1) | (theta_d >= math.pi / 2)
            rays[back] = 1e6
            ideal_k = ideal_camera.camera_matrix()
            ideal = (rays * np.diag(ideal_k)[:2] + ideal_k[:2, 2]).reshape(camera.height, camera.width, 2)
        else:
            ideal = cv2.undistortPoints(distorted, k, d, R=None, P=k, criteria=criteria).reshape(camera.height, camera.width, 2)
        self.map_x, self.map_y = cv2.convertMaps(ideal[..., 0].astype(np.float32), ideal[..., 1].astype(np.float32),
                                                 cv2.CV_16SC2)

    def __call__(self, image: np.ndarray) -> np.ndarray:
        return cv2.remap(image, self.map_x, self.map_y, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT)


class SceneRenderer:
    """Renders the table state held in a qpos vector of the foos_sim model (same joints, same order)."""

    def __init__(self, base_mjcf: str, layout: MarkerLayout, options: RenderOptions):
        self.options = options
        self.camera = options.camera
        # The scene is filmed by an ideal pinhole; the lens (distortion, fisheye) is applied to its image.
        self.ideal_camera = options.camera.render_camera()
        self.model = build_scene_model(base_mjcf, layout, self.ideal_camera, options.hands)
        hide_cover(self.model)
        set_rod_finish(self.model)
        set_ball_colour(self.model, options.ball_colour)
        for team, rgb in (("home", options.home_colour), ("away", options.away_colour)):
            if rgb is not None:
                set_team_colour(self.model, team, rgb)
        set_lighting(self.model, options.lighting)
        self.data = mujoco.MjData(self.model)
        ideal = self.ideal_camera
        self.renderer = mujoco.Renderer(self.model, ideal.height, ideal.width)
        self.segmenter: Optional[mujoco.Renderer] = None
        if options.visibility:
            self.segmenter = mujoco.Renderer(self.model, ideal.height, ideal.width)
            self.segmenter.enable_segmentation_rendering()
        lens = options.camera.fisheye or any(options.camera.distortion)
        self.distortion = DistortionMap(options.camera) if lens else None
        ball = self.model.joint(BALL_JOINT)
        self.ball_qpos = slice(ball.qposadr[0], ball.qposadr[0] + 3)
        self.ball_geom = self.model.geom("ball").id
        self.ball_radius = float(self.model.geom_size[self.ball_geom][0])
        self.rod_qpos = np.array([self.model.joint(n).qposadr[0] for n in JOINT_NAMES])
        self.rng = np.random.default_rng(options.seed)
        self.hand_mocap = int(self.model.body(HAND_BODY).mocapid[0]) if options.hands else None

    def _pose(self, qpos: np.ndarray, hidden: bool, hand: Optional[HandPose] = None) -> None:
        self.data.qpos[:] = qpos
        if hidden:
            self.data.qpos[self.ball_qpos] = (0.0, 0.0, HIDDEN_Z)
        if self.hand_mocap is not None:
            self.data.mocap_pos[self.hand_mocap] = hand.position if hand is not None else (0.0, 0.0, AWAY_Z)
            self.data.mocap_quat[self.hand_mocap] = hand.quat if hand is not None else (1.0, 0.0, 0.0, 0.0)
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)  # camera and light poses are not part of kinematics

    def render_rgb(self, qpos: np.ndarray, hidden: bool = False, hand: Optional[HandPose] = None) -> np.ndarray:
        self._pose(qpos, hidden, hand)
        self.renderer.update_scene(self.data, CAMERA_NAME)
        return self.renderer.render()

    def visible_fraction(self, qpos: np.ndarray, hidden: bool = False, hand: Optional[HandPose] = None) -> float:
        if self.segmenter is None:
            return math.nan
        if hidden:
            return 0.0
        self._pose(qpos, False, hand)
        self.segmenter.update_scene(self.data, CAMERA_NAME)
        seg = self.segmenter.render()
        seen = np.count_nonzero((seg[..., 0] == self.ball_geom) & (seg[..., 1] == int(mujoco.mjtObj.mjOBJ_GEOM)))
        centre = self.data.qpos[self.ball_qpos].copy()
        # Measured in the ideal render: the share of the disc in view does not depend on the lens (the
        # black corners beyond a fisheye render's reach aside).
        depth = float(self.camera.depth(centre)[0])
        if depth <= self.ball_radius:
            return 0.0
        focal = self.ideal_camera.camera_matrix()[0, 0]
        expected = math.pi * (focal * self.ball_radius / depth) ** 2
        return float(min(1.0, seen / expected))

    def finish(self, frames: list[np.ndarray]) -> np.ndarray:
        """Average the sub-frames, add the lens and the sensor noise; returns BGR uint8 for the writer."""
        image = frames[0].astype(np.float32) if len(frames) == 1 else np.mean(np.stack(frames), axis=0, dtype=np.float32)
        if self.distortion is not None:
            image = self.distortion(image)
        if self.options.noise > 0:
            image += self.rng.normal(0.0, self.options.noise, image.shape).astype(np.float32)
        return cv2.cvtColor(np.clip(image + 0.5, 0, 255).astype(np.uint8), cv2.COLOR_RGB2BGR)

    def close(self) -> None:
        self.renderer.close()
        if self.segmenter is not None:
            self.segmenter.close()


StateAt = Callable[[float], tuple[np.ndarray, np.ndarray, bool]]
"""Advance a rollout to time t (never backwards) and return (qpos, ball velocity, ball hidden)."""
HandAt = Callable[[float, np.ndarray], Optional[HandPose]]
"""The hand's pose at time t, given the ball centre (called right after StateAt for the same t); None: away."""


def frame_times(k: int, fps: float, subframes: int, exposure: float) -> list[float]:
    t = k / fps
    if subframes <= 1:
        return [t]
    return [t + ((j + 0.5) / subframes - 0.5) * exposure / fps for j in range(subframes)]


def render_frames(renderer: SceneRenderer, state_at: StateAt, n_frames: int,
                  hand_at: Optional[HandAt] = None) -> Iterator[tuple[np.ndarray, FrameTruth]]:
    """Yields (BGR frame, its truth) for frames 0..n_frames-1. hand_at: where the player's hand is (a renderer
    built with hands)."""
    o = renderer.options
    fps = renderer.camera.fps
    for k in range(n_frames):
        t_k = k / fps
        subs = frame_times(k, fps, o.subframes, o.exposure)
        images: list[np.ndarray] = []
        truth: Optional[FrameTruth] = None
        in_sight = 0  # sub-frames with the ball in sight (not picked up)
        for t in sorted(subs + [t_k]) if o.subframes > 1 else [t_k]:
            qpos, velocity, hidden = state_at(max(t, 0.0))
            hand = hand_at(max(t, 0.0), qpos[renderer.ball_qpos]) if hand_at is not None else None
            if t == t_k and truth is None:
                position = qpos[renderer.ball_qpos].copy()
                if hidden:
                    position[:] = math.nan
                truth = FrameTruth(t_k, position, velocity.copy() if not hidden else np.full(3, math.nan),
                                   renderer.visible_fraction(qpos, hidden, hand), qpos[renderer.rod_qpos].copy())
                if o.subframes > 1:
                    continue
            in_sight += not hidden
            images.append(renderer.render_rgb(qpos, hidden, hand))
        if o.subframes > 1 and truth.visible > 0:
            # The frame is the mean of its exposure: a ball put down or picked up during it is in sight
            # for part of it and leaves a ghost of that share of its contrast, so its visible share is
            # scaled by it too (occlusion by figures is taken at t_k alone).
            truth.visible *= in_sight / len(images)
        yield renderer.finish(images), truth


def write_truth(path: Path, truths: list[FrameTruth]) -> None:
    rows = np.array([[i, f.t, *f.position, *f.velocity, f.visible] for i, f in enumerate(truths)], float)
    header = "frame,t,x,y,z,vx,vy,vz,visible"
    fmt = ["%d", "%.9f"] + ["%.7f"] * 6 + ["%.4f"]
    np.savetxt(path, rows, delimiter=",", header=header, comments="", fmt=fmt)


def write_joints(path: Path, truths: list[FrameTruth]) -> None:
    """frame,t and the 16 rod joints at each frame time: what /joint_states says on an instrumented table."""
    rows = np.array([[i, f.t, *f.joints] for i, f in enumerate(truths)], float)
    fmt = ["%d", "%.9f"] + ["%.7f"] * len(JOINT_NAMES)
    np.savetxt(path, rows, delimiter=",", header="frame,t," + ",".join(JOINT_NAMES), comments="", fmt=fmt)


def read_joints(path: str | Path) -> tuple[np.ndarray, list[str], np.ndarray]:
    """(t, joint names, positions (N, J)) of a joints CSV written by write_joints."""
    data = np.genfromtxt(path, delimiter=",", names=True)
    names = [n for n in data.dtype.names if n not in ("frame", "t")]
    data = np.atleast_1d(data)
    return np.asarray(data["t"], float), names, np.stack([np.asarray(data[n], float) for n in names], axis=1)


def read_truth(path: str | Path) -> dict[str, np.ndarray]:
    data = np.genfromtxt(path, delimiter=",", names=True)
    return {name: np.asarray(data[name], float) for name in data.dtype.names}
