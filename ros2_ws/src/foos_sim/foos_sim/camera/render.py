"""The synthetic camera: renders a simulated (or recorded) rollout to an mp4 plus its ground truth.

Frame k is exposed around t_k = k / fps; its ground truth is the ball centre at t_k. With motion blur,
`subframes` renders spread over `exposure` of the frame interval, centred on t_k, are averaged, and the
ball's visible share is that at t_k times the share of the sub-frames it is in sight in (not picked up).
"""
from __future__ import annotations

import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Callable, Iterator, Optional, Sequence

import cv2
import mujoco
import numpy as np
import yaml
from tqdm import tqdm

from foos_core.camera_model import CameraConfig
from foos_core.markers import MarkerLayout
from foos_core.names import BALL_JOINT, JOINT_NAMES

from .errors import RenderError
from .hands import AWAY_Z, HAND_BODY, HandPose
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
    hands: bool = False  # the scene has a player's hand (foos_sim.camera.hands), posed per frame by render_frames' hand_at
    # Shadows are most of a frame's cost on a software renderer (Mesa's llvmpipe: 3x); a video to watch can do
    # without them, a video to track is rendered with them.
    shadows: bool = True
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
        self.renderer.scene.flags[mujoco.mjtRndFlag.mjRND_SHADOW] = options.shadows
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


Bgr = tuple[int, int, int]
MIN_MARK_PIXELS = 4  # a ball is drawn at least this large (radius, px), so a small video still shows it


@dataclass(frozen=True)
class BallMark:
    """A ball drawn over the rendered image, for a viewer to compare: the measured ball, a table's prediction.

    style: `dot` (filled, 0.6 of the ball: the rendered ball stays visible around it), `disc` (filled, the
    ball's size) or `ring` (an outline ring_gap px outside the ball; rings of several tables with different gaps
    stay apart from each other and from the disc they follow where they coincide)."""

    label: str
    colour: Bgr
    style: str = "dot"
    ring_gap: int = 2


MEASURED_COLOUR: Bgr = (255, 0, 255)  # magenta: far from the field's green, the teams' red and blue, every ball colour
LEGEND_TEXT: Bgr = (240, 240, 240)


class BallOverlay:
    """Draws BallMarks at table-frame ball centres through the camera (lens included), and a small legend."""

    def __init__(self, camera: CameraConfig, marks: Sequence[BallMark], ball_radius: float):
        self.camera, self.marks, self.ball_radius = camera, list(marks), ball_radius
        self.focal = float(camera.camera_matrix()[0, 0])
        self.text_scale = max(0.35, camera.width / 1400)

    def pixel(self, position: np.ndarray) -> tuple[np.ndarray, float]:
        """The pixel of a ball centre and the ball's radius there, px."""
        point = np.asarray(position, float).reshape(1, 3)
        depth = float(self.camera.depth(point)[0])
        radius = self.focal * self.ball_radius / max(depth, 1e-3)
        return self.camera.project(point)[0], max(radius, MIN_MARK_PIXELS)

    def _draw(self, image: np.ndarray, mark: BallMark, centre, radius: float) -> None:
        shift = 4  # sub-pixel positions: cv2 draws in 1/16 px
        c = (int(round(centre[0] * 16)), int(round(centre[1] * 16)))
        if mark.style == "ring":
            # 3 px wide: a thinner ring loses its colour to the video's chroma subsampling (2x2 pixels share one)
            cv2.circle(image, c, int(round((radius + mark.ring_gap) * 16)), mark.colour, 3, cv2.LINE_AA, shift)
            return
        r = radius * (0.6 if mark.style == "dot" else 1.0)
        cv2.circle(image, c, int(round((r + 1) * 16)), (20, 20, 20), -1, cv2.LINE_AA, shift)
        cv2.circle(image, c, int(round(r * 16)), mark.colour, -1, cv2.LINE_AA, shift)

    def __call__(self, image: np.ndarray, positions: Sequence[Optional[np.ndarray]],
                 notes: Optional[Sequence[str]] = None, caption: str = "",
                 trails: Optional[Sequence[Optional[np.ndarray]]] = None) -> np.ndarray:
        """Draws each mark at its position (None or NaN: not drawn), then the legend; image is BGR, changed in place.
        notes: a text per mark appended to its legend line (e.g. its distance to the measurement); trails: per mark,
        the ball centres (k, 3) it came along, drawn as a thin line under the marks."""
        for mark, trail in zip(self.marks, trails or []):
            finite = trail[np.all(np.isfinite(trail), axis=1)] if trail is not None else np.zeros((0, 3))
            if len(finite) >= 2:
                line = np.round(self.camera.project(finite) * 16).astype(np.int32)
                cv2.polylines(image, [line], False, mark.colour, 1, cv2.LINE_AA, 4)
        for mark, position in zip(self.marks, positions):
            if position is not None and np.all(np.isfinite(position)):
                self._draw(image, mark, *self.pixel(position))
        self.legend(image, notes, caption)
        return image

    def legend(self, image: np.ndarray, notes: Optional[Sequence[str]] = None, caption: str = "") -> None:
        scale, font = self.text_scale, cv2.FONT_HERSHEY_SIMPLEX
        lines = [f"{m.label}{'  ' + notes[i] if notes and notes[i] else ''}" for i, m in enumerate(self.marks)]
        if caption:
            lines.append(caption)
        line_height = int(round(22 * scale / 0.5))
        width = max(cv2.getTextSize(text, font, scale, 1)[0][0] for text in lines) + 3 * line_height // 2 + 8
        height = line_height * len(lines) + 6
        box = image[2:2 + height, 2:2 + width]
        box[:] = (box * 0.35).astype(np.uint8)  # darkened, so the legend reads over the table
        swatch = line_height * 0.3
        for i, text in enumerate(lines):
            y = 2 + line_height * (i + 1) - line_height // 4
            if i < len(self.marks):  # every swatch the same size: a ring just outside it
                self._draw(image, replace(self.marks[i], ring_gap=1), (8 + line_height / 2, y - line_height * 0.3), swatch)
            cv2.putText(image, text, (8 + line_height, y), font, scale, LEGEND_TEXT, 1, cv2.LINE_AA)


FrameOverlay = Callable[[int, np.ndarray, FrameTruth], None]
"""Draws on frame k's BGR image (in place), given its truth."""


def write_video(out: Path, renderer: SceneRenderer, state_at: StateAt, n_frames: int, truths: list[FrameTruth],
                hand_at: Optional[HandAt] = None, overlay: Optional[FrameOverlay] = None, quiet: bool = False,
                desc: str = "render_video") -> None:
    """Renders frames 0..n_frames-1 into an mp4v video at out, appending their truths to truths as it goes (so what
    was rendered before an interruption keeps its truth)."""
    camera = renderer.camera
    out.parent.mkdir(parents=True, exist_ok=True)
    writer = cv2.VideoWriter(str(out), cv2.VideoWriter_fourcc(*"mp4v"), camera.fps, (camera.width, camera.height))
    if not writer.isOpened():
        raise RenderError(f"{out}: OpenCV cannot write an mp4v video here")
    try:
        for frame, truth in tqdm(render_frames(renderer, state_at, n_frames, hand_at), total=n_frames,
                                 desc=desc, unit="frame", disable=quiet):
            if overlay is not None:
                overlay(len(truths), frame, truth)
            writer.write(frame)
            truths.append(truth)
    finally:
        writer.release()


def write_camera(path: Path, camera: CameraConfig) -> None:
    """The camera a video was filmed with, and its OpenCV intrinsics (`intrinsics:`, what track_video takes)."""
    tree = {key: (list(v) if isinstance(v, tuple) else v) for key, v in camera.__dict__.items()}
    tree["intrinsics"] = {"model": camera.model, "image_width": camera.width, "image_height": camera.height,
                          "camera_matrix": camera.camera_matrix().round(6).tolist(),
                          "dist_coeffs": [float(v) for v in camera.dist_coeffs()]}
    path.write_text(yaml.safe_dump(tree, sort_keys=False))


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
