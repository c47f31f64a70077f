"""`--field-corners auto` against the truth: renders of the simulated camera from random cameras, and real footage
with tags.

A render case (random_case) draws, from a seed: the camera's place (overhead at 1.1-2.6 m, shifted and tilted
up to 20 degrees; or oblique from behind either goal or beside either side wall, 40-70 degrees above the
horizon), its roll, its lens (a pinhole, a pinhole with radial distortion, or a fisheye, given to the finder as
--intrinsics would be, or, for a fisheye, not given), the image size (640x480 to 1920x1080), the light, and the
felt's colour (green, blue, red, grey or black). The truth is the camera model's projection of the field's corners;
the finder's order follows its rule for the home end (field_auto._table_order), so the truth is put in that order.

    ./scripts/bench_vision --field-auto 24                          # render cases 0-23
    ./scripts/bench_vision --field-auto 24 --field-auto-from 24     # cases 24-47
"""
from __future__ import annotations

import math
import time
from dataclasses import dataclass
from typing import Optional

import numpy as np

from foos_core.camera_model import CameraConfig, Intrinsics
from foos_core.markers import load_markers
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.camera.render import RenderOptions, SceneRenderer, render_frames
from foos_sim.camera.scenarios import SimRollout
from foos_sim.model_builder import build_mjcf
from foos_sim.simulation import TableSimulation

from .camera.field_auto import FieldNotFound, find_field_corners, home_end_first
from .camera.field_corners import FieldCorners
from .camera.field_view import FieldView, TagFitStats
from .tracking.tracker import TrackerConfig

# The felt's colours a render is given (the model's texture colour, linear RGB 0-1). The first is foos_sim's own.
FELT_COLOURS = {
    "green": (0.10, 0.45, 0.18),
    "blue": (0.08, 0.22, 0.55),
    "red": (0.55, 0.10, 0.10),
    "grey": (0.35, 0.35, 0.36),
    "black": (0.06, 0.06, 0.07),
}
SIM_FELT_RGB = "0.10 0.45 0.18"  # foos_sim.model_builder's felt texture (rgb1)
SIZES = ((640, 480), (800, 600), (1280, 720), (1920, 1080))


@dataclass
class RenderCase:
    name: str
    camera: CameraConfig
    felt: str
    lighting: float
    intrinsics_given: bool  # the finder is told the lens (--intrinsics)


def random_case(seed: int, sizes=SIZES, felts=tuple(FELT_COLOURS)) -> RenderCase:
    rng = np.random.default_rng(seed)
    width, height = sizes[rng.integers(len(sizes))]
    view = rng.choice(["overhead", "overhead", "behind", "beside"])
    if view == "overhead":
        position = (rng.uniform(-0.1, 0.1), rng.uniform(-0.15, 0.15), rng.uniform(1.1, 2.6))
        tilt = math.radians(rng.uniform(0, 20))
        heading = rng.uniform(0, 2 * math.pi)
        look_at = (position[0] + position[2] * math.tan(tilt) * math.cos(heading) * 0.3,
                   position[1] + position[2] * math.tan(tilt) * math.sin(heading) * 0.3, 0.0)
        roll = rng.choice([0.0, math.pi / 2, math.pi, 3 * math.pi / 2]) + rng.uniform(-0.15, 0.15)
        up = (-math.cos(roll), math.sin(roll), 0.0)
    else:
        elevation = math.radians(rng.uniform(40, 70))
        distance = rng.uniform(1.6, 2.4)
        if view == "behind":
            azimuth = rng.choice([-math.pi / 2, math.pi / 2]) + rng.uniform(-0.25, 0.25)
        else:
            azimuth = rng.choice([0.0, math.pi]) + rng.uniform(-0.25, 0.25)
        position = (distance * math.cos(elevation) * math.cos(azimuth),
                    distance * math.cos(elevation) * math.sin(azimuth), distance * math.sin(elevation))
        look_at = (rng.uniform(-0.05, 0.05), rng.uniform(-0.08, 0.08), 0.0)
        up = (0.0, 0.0, 1.0)
    lens = rng.choice(["pinhole", "radial", "fisheye", "fisheye-unknown"])
    model, distortion = "pinhole", ()
    if lens == "radial":
        distortion = (rng.uniform(-0.25, 0.05), rng.uniform(-0.02, 0.05))
    elif lens.startswith("fisheye"):
        model, distortion = "fisheye", (rng.uniform(-0.02, 0.08), rng.uniform(-0.03, 0.01), 0.0, 0.0)
    camera = CameraConfig(name=f"case{seed}", width=int(width), height=int(height), fps=30.0,
                          position=tuple(float(v) for v in position), look_at=tuple(float(v) for v in look_at),
                          up=tuple(float(v) for v in up), fovy=45.0, distortion=tuple(float(v) for v in distortion),
                          model=model)
    camera = camera.with_(fovy=_fovy_to_fit(camera, rng.uniform(1.1, 1.5)))
    felt = str(rng.choice(list(felts)))
    return RenderCase(f"{seed}:{view}/{lens}/{width}x{height}/{felt}", camera, felt, float(rng.uniform(0.6, 1.4)),
                      lens != "fisheye-unknown")


def _fovy_to_fit(camera: CameraConfig, margin: float) -> float:
    """The vertical field of view that holds the table with its walls (0.1 m round the field), margin times its
    extent from the image's centre."""
    t = TableGeometry.nominal()
    x, y = t.half_width + 0.1, t.half_length + 0.1
    points = np.array([(sx * x, sy * y, z) for sx in (-1, 1) for sy in (-1, 1) for z in (0.0, 0.2)])
    axes = camera.axes()
    relative = points - np.asarray(camera.position)
    depth = relative @ -axes[2]
    across = np.abs(relative @ axes[0]) / depth
    up = np.abs(relative @ axes[1]) / depth
    need = max(float(np.max(up)), float(np.max(across)) * camera.height / camera.width) * margin
    fovy = math.degrees(2 * math.atan(need))
    if camera.fisheye:
        fovy = math.degrees(2 * math.atan(need)) * 1.05
    return float(min(fovy, 120.0))


def true_corners(camera: CameraConfig, table: TableGeometry) -> np.ndarray:
    x, y = table.half_width, table.half_length
    return camera.project(np.array([(-x, -y, 0.0), (x, -y, 0.0), (x, y, 0.0), (-x, y, 0.0)]))


def render_frames_of(case: RenderCase, frames: int = 3, seed: int = 0) -> list[np.ndarray]:
    """frames of the table in play, rendered by foos_sim's camera with the case's felt, light and lens."""
    params = load_params(None)
    sim = TableSimulation(params=params)
    rollout = SimRollout(sim, "play", seed=seed)
    rgb = " ".join(f"{c:.3f}" for c in FELT_COLOURS[case.felt])
    mjcf = build_mjcf(params=params).replace(SIM_FELT_RGB, rgb)
    renderer = SceneRenderer(mjcf, load_markers(None), RenderOptions(camera=case.camera, lighting=case.lighting,
                                                                     seed=seed))
    try:
        return [frame for frame, _ in render_frames(renderer, rollout.state_at, frames)]
    finally:
        renderer.close()


@dataclass
class CaseResult:
    name: str
    errors: Optional[np.ndarray]  # px per corner; None: not found
    confidence: float
    seconds: float
    note: str
    fitted_errors: Optional[np.ndarray] = None  # px per corner after the tracker's fit to the table's edges


def run_case(case: RenderCase, frames: int = 3) -> CaseResult:
    table = TableGeometry.nominal()
    images = render_frames_of(case, frames)
    wall_height = float(load_params(None)["field"]["wall_height"])
    intrinsics: Optional[Intrinsics] = case.camera.intrinsics() if case.intrinsics_given else None
    truth = home_end_first(true_corners(case.camera, table))
    started = time.perf_counter()
    try:
        found = find_field_corners(images, table.half_width, table.half_length, table.goal_half_width, wall_height,
                                   intrinsics)
    except FieldNotFound as error:
        return CaseResult(case.name, None, 0.0, time.perf_counter() - started, str(error))
    seconds = time.perf_counter() - started
    errors = np.linalg.norm(found.pixels - truth, axis=1)
    # What the tracker then makes of them: the corners fitted to the table's edges on the first frame, as a run
    # with these corners given does (FieldView, corner_refine).
    view = FieldView(FieldCorners(found.pixels), None, intrinsics, TrackerConfig().fovy_hint, TagFitStats())
    view.refit(images[0])
    fitted = np.linalg.norm(view.corner_refinement.pixels - truth, axis=1)
    return CaseResult(case.name, errors, found.confidence, seconds, found.summary(), fitted)


def run_field_auto(cases: int, first_seed: int = 0) -> int:
    print(f"{'case':48s} {'corner errors px':28s} {'max':>6s} {'conf':>5s} {'s':>5s} {'fitted to edges: max':>21s}")
    worst, fitted = [], []
    for seed in range(first_seed, first_seed + cases):
        result = run_case(random_case(seed))
        if result.errors is None:
            print(f"{result.name:48s} not found: {result.note}")
            worst.append(math.inf)
            fitted.append(math.inf)
            continue
        worst.append(float(result.errors.max()))
        fitted.append(float(result.fitted_errors.max()))
        print(f"{result.name:48s} {' '.join(f'{e:6.2f}' for e in result.errors):28s} {result.errors.max():6.2f} "
              f"{result.confidence:5.2f} {result.seconds:5.2f} {result.fitted_errors.max():21.2f}")
    print(f"renders: {sum(w <= 4.0 for w in worst)} of {len(worst)} cases with every corner within 4 px as found, "
          f"{sum(w <= 4.0 for w in fitted)} after the fit to the table's edges")
    return 0
