"""A game's ball against its figures: the camera's clock and the figures' restitution, before the ball fit.

Both read the ball's kinks (sudden turns of its path away from the walls: figure_kinks) against the
figures posed from /joint_states. The camera latency comes first: the detections are taken back to
their capture time by it, on the encoders' clock, before anything else uses their stamps (the figure
contacts that cut the tracks, the figure bounces, the rolling fit).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from foos_core.table_geometry import TableGeometry

from .camera_clock import CameraClock, find_camera_latency
from .camera_clock import describe as describe_camera
from .figure_bounces import FigureRestitution, find_figure_restitution
from .figure_bounces import describe as describe_figures
from .figure_contacts import FigureModel, JointTrack
from .figure_kinks import detection_noise, find_kinks


@dataclass
class GameBall:
    t: np.ndarray  # detection stamps at capture (the camera latency, where named, taken off)
    figure_model: FigureModel  # the figures of the table, for the contacts that cut the ball's tracks
    camera: CameraClock
    figures: FigureRestitution

    def effects(self) -> list[dict]:
        """The named effects, described, in the contract's vocabulary (camera first)."""
        nominal = self.figures.block.get("nominal")
        return ([{**e, "description": describe_camera(e)} for e in self.camera.effects]
                + [{**e, "description": describe_figures(e, nominal)} for e in self.figures.effects])


def camera_and_figures(t: np.ndarray, xy: np.ndarray, geometry: TableGeometry, params: dict, joints: JointTrack,
                       seed: int = 0, progress: Callable[[str], None] = lambda message: None) -> GameBall:
    figure_model = FigureModel(params)
    noise = detection_noise(t, xy)
    progress("finding the ball's kinks at the figures, and the camera's latency against the encoders")
    kinks = find_kinks(t, xy, geometry, noise)
    camera = find_camera_latency(kinks, figure_model, joints, noise, seed)
    if camera.delay is not None:
        t = t - camera.delay  # back to capture time, on the encoders' clock
        kinks = find_kinks(t, xy, geometry, noise)
    progress("fitting the figures' restitution on MuJoCo replays of the figure bounces")
    figures = find_figure_restitution(kinks, t, xy, figure_model, joints, params, noise)
    return GameBall(t, figure_model, camera, figures)
