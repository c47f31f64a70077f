"""Ball-figure contacts in a game: where the figures were at each detection, and which frames a figure touched.

tracks.analyse cuts a ball track into flights at the frames a `contact_frames(t, xy)` object marks, as it
does at walls. Two such objects:

- `PosedFigures` (a bag with /joint_states): every figure is placed by the MuJoCo model's own geometry posed
  at each detection's time (joint positions interpolated between encoder stamps). Each rod is a body with
  two joints along +x through its axis (slide, then rotate), so a figure geom's pose is its pose at the
  zero pose moved by the slide and turned by the angle; the constructor checks that rule against
  mj_kinematics at random poses, so the model stays the one place the geometry lives. A frame is a contact
  frame when the ball (a sphere resting on the field) is within FIGURE_ZONE of a figure at the frame or
  anywhere along the way to its neighbours (figures and ball interpolated between frames: a kicking foot
  moves up to 3 m/s, 25 mm a frame), or within reach of one with its velocity changing as only a touch
  changes it. While a figure holds or pins the ball every frame is a contact frame, so it is left out. The
  RodLines rule below applies too, on every frame: a ball kicked into the air meets figures those poses of a
  ball on the field cannot see.
- `RodLines` (no joint states): contact events come from velocity changes within a figure's reach of a rod
  line (the rods' y from the parameter file, the reach from the model's figures at every angle). The
  threshold is far above what the detection noise makes, so free rolls with no figure in play are cut
  nowhere and keep their results exactly.
"""
from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mujoco
import numpy as np
from numpy.lib.stride_tricks import sliding_window_view as windows

from foos_core.names import AXES, JOINT_NAMES, RODS, TEAMS, figure_geom_name, joint_name
from foos_core.table_geometry import TableGeometry
from foos_sim.model_builder import model_from_params

from .tracks import contact_frames, velocity_change

FIGURE_ZONE = 0.005  # m: ball surface this close to a figure's (noise ~1.5 mm, encoder interpolation) is a touch
CHANGE_WITH_JOINTS = 0.25  # m/s between the 6-frame windows either side (as at walls)
WALL_OR_FIGURE = 0.015  # m: a velocity change by a wall contact is also a figure's when a figure is this close
SWEEP_STEP = 0.004  # m: figures and ball are sampled between frames at least this finely
MAX_SWEEP_SAMPLES = 24
ROD_CHANGE_NOISE_SIGMAS = 8.0  # without joint states: the change must be this many times its noise...
ROD_CHANGE_FLOOR = 0.35  # m/s ...and at least this (a slide after a wall bounce changes ~0.15 m/s a window)
WINDOW = 6  # frames each side of the velocity-change test, as tracks.contact_frames
PEAK_HALF_WIDTH = 3  # frames either side of a velocity-change peak left out without joint states


def _rotation_x(angle: np.ndarray) -> np.ndarray:
    """(..., 3, 3) rotations about +x."""
    c, s = np.cos(angle), np.sin(angle)
    one, zero = np.ones_like(c), np.zeros_like(c)
    return np.stack([np.stack([one, zero, zero], -1), np.stack([zero, c, -s], -1), np.stack([zero, s, c], -1)], -2)


@dataclass(frozen=True)
class _Geoms:
    """Every figure geom (boxes), at the zero pose, with the columns of its rod's slide and rotate joints."""

    names: tuple[str, ...]
    axis_origin: np.ndarray  # (G, 3) the rod axis point the geom turns about
    offset: np.ndarray  # (G, 3) geom centre - axis_origin at the zero pose
    mat: np.ndarray  # (G, 3, 3) geom frame at the zero pose
    half: np.ndarray  # (G, 3) box half sizes
    slide: np.ndarray  # (G,) column in JOINT_NAMES
    rotate: np.ndarray  # (G,)
    rod: np.ndarray  # (G,) index of the rod (team, rod) in ROD_KEYS


ROD_KEYS = tuple((team, rod) for team in TEAMS for rod in RODS)


def _figure_geoms(model: mujoco.MjModel, params: dict) -> _Geoms:
    data = mujoco.MjData(model)
    mujoco.mj_kinematics(model, data)
    names, origin, offset, mats, half, slide, rotate, rod_index = [], [], [], [], [], [], [], []
    for r, (team, rod) in enumerate(ROD_KEYS):
        joints = [model.joint(joint_name(team, rod, axis)) for axis in AXES]
        for joint in joints:
            if not (np.allclose(joint.axis, (1, 0, 0)) and np.allclose(joint.pos, 0)):
                raise ValueError(f"joint {joint.name} is not along +x through its rod's axis: the figure poses assume it")
        body = int(joints[0].bodyid[0])
        for i in range(int(params["rods"]["layout"][f"{team}_{rod}"]["figures"])):
            for part in ("body", "foot"):
                geom = model.geom(figure_geom_name(team, rod, i, part))
                if geom.type[0] != mujoco.mjtGeom.mjGEOM_BOX:
                    raise ValueError(f"figure geom {geom.name} is not a box")
                names.append(geom.name)
                origin.append(data.xpos[body].copy())
                offset.append(data.geom_xpos[geom.id] - data.xpos[body])
                mats.append(data.geom_xmat[geom.id].reshape(3, 3).copy())
                half.append(geom.size.copy())
                slide.append(JOINT_NAMES.index(joint_name(team, rod, "slide")))
                rotate.append(JOINT_NAMES.index(joint_name(team, rod, "rotate")))
                rod_index.append(r)
    return _Geoms(tuple(names), np.array(origin), np.array(offset), np.array(mats), np.array(half),
                  np.array(slide), np.array(rotate), np.array(rod_index))


def _sum_over_j(terms) -> np.ndarray:
    """terms j = 0, 1, 2 added in that order (as np.einsum reduces a length-3 axis)."""
    first, second, third = terms
    first += second
    first += third
    return first


class FigureModel:
    """The figures of a table (its parameter file) as the MuJoCo model builds them, posable by joint positions."""

    def __init__(self, params: dict):
        self.model = model_from_params(params, "reference")
        self.geoms = _figure_geoms(self.model, params)
        self.ball_radius = float(params["ball"]["radius"])
        self.rod_y = np.array([float(params["rods"]["layout"][f"{team}_{rod}"]["y"]) for team, rod in ROD_KEYS])
        self._check_against_mujoco()

    def poses(self, q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Centres (n, G, 3) and frames (n, G, 3, 3) of every figure geom at joint positions q (n, 16)."""
        g = self.geoms
        turn = _rotation_x(q[:, g.rotate])  # (n, G, 3, 3)
        # The 3-term products summed as einsum sums them (j = 0, 1, 2: the same bits), without einsum's per-element
        # loop over such short axes: a fifth of a robot-table trial's calibration once its drive fit was compiled (robot-cpu-6).
        centre = g.axis_origin[None] + _sum_over_j(turn[..., :, j] * g.offset[None, :, None, j] for j in range(3))
        centre[..., 0] += q[:, g.slide]
        return centre, _sum_over_j(turn[..., :, j, None] * g.mat[None, :, None, j, :] for j in range(3))

    def distance(self, xy: np.ndarray, q: np.ndarray, geoms: np.ndarray | None = None) -> np.ndarray:
        """(n,) gap between the ball (centre at xy, resting on the field) and the nearest figure (of `geoms`,
        a mask; all by default); <= 0 touching."""
        centre, mat = self.poses(q)
        half = self.geoms.half
        if geoms is not None:
            centre, mat, half = centre[:, geoms], mat[:, geoms], half[geoms]
        ball = np.concatenate([xy, np.full((len(xy), 1), self.ball_radius)], axis=1)
        apart = ball[:, None, :] - centre
        local = _sum_over_j(mat[:, :, j, :] * apart[:, :, j, None] for j in range(3))  # ball centre in each box's frame
        outside = np.abs(local) - half[None]
        gap = np.linalg.norm(np.maximum(outside, 0.0), axis=-1) + np.minimum(outside.max(axis=-1), 0.0)
        return gap.min(axis=1) - self.ball_radius

    def _check_against_mujoco(self) -> None:
        data = mujoco.MjData(self.model)
        rng = np.random.default_rng(0)
        q = np.stack([rng.uniform(-0.1, 0.1, 16), rng.uniform(-np.pi, np.pi, 16)], axis=1)
        q = np.where(np.array(["slide" in n for n in JOINT_NAMES]), q[:, 0], q[:, 1])
        for name, value in zip(JOINT_NAMES, q):
            data.qpos[self.model.joint(name).qposadr[0]] = value
        mujoco.mj_kinematics(self.model, data)
        centre, mat = self.poses(q[None])
        ids = [self.model.geom(n).id for n in self.geoms.names]
        if not (np.allclose(centre[0], data.geom_xpos[ids], atol=1e-9)
                and np.allclose(mat[0], data.geom_xmat[ids].reshape(-1, 3, 3), atol=1e-9)):
            raise ValueError("the figure poses no longer follow the model's kinematics (rod joints changed?)")

    @property
    def reach_y(self) -> float:
        """m: the farthest in y from its rod's axis that a figure can touch a ball on the field, at any angle."""
        return _reach_y(self)


@lru_cache(maxsize=4)
def _reach_y(figures: FigureModel) -> float:
    g = figures.geoms
    r0 = int(np.flatnonzero(g.rod == 0)[0])  # one rod's figure: all figures are alike
    own = g.rod == 0
    angles = np.radians(np.arange(0.0, 360.0, 1.0))
    q = np.zeros((len(angles), 16))
    q[:, g.rotate[r0]] = angles
    dy = np.arange(0.0, 0.15, 0.0005)
    x0 = figures.poses(q[:1])[0][0, r0, 0]
    best = 0.0
    for d in dy:
        xy = np.tile([x0, figures.rod_y[0] + d], (len(angles), 1))
        if np.any(figures.distance(xy, q, own) <= 0) or np.any(figures.distance(xy - [0, 2 * d], q, own) <= 0):
            best = d
    return float(best)



def _spread(frames: np.ndarray, half: int) -> np.ndarray:
    """Frames within `half` frames of a marked one. (np.convolve's "same" mode returns the kernel's length for a
    track shorter than the kernel: stretches between figure contacts can be.)"""
    return np.convolve(np.asarray(frames, dtype=float), np.ones(2 * half + 1))[half: half + len(frames)] > 0


@dataclass
class JointTrack:
    """Encoder samples: stamps (n,) and the 16 joint positions (n, 16) in JOINT_NAMES order."""

    t: np.ndarray
    q: np.ndarray

    def at(self, times: np.ndarray) -> np.ndarray:
        """(n, 16) joint positions interpolated at `times` (held at the ends): np.interp's values, with one search
        for all 16 columns (np.interp per column copied each strided column of a 1 kHz game's samples every call)."""
        times = np.asarray(times, dtype=float)
        after = np.clip(np.searchsorted(self.t, times, side="right"), 1, len(self.t) - 1)
        t0, t1 = self.t[after - 1], self.t[after]
        share = np.clip((times - t0) / (t1 - t0), 0.0, 1.0)[..., None]
        q0, q1 = self.q[after - 1], self.q[after]
        return q0 + share * (q1 - q0)


class RodLines:
    """Contact frames without joint states: sudden velocity changes within a figure's reach of a rod line.

    A change is judged at its peak (the frame whose windows straddle the touch): the largest change within
    `resolution` frames (a window by default), so that two touches closer than that are one. A peak within
    `resolution` frames of a wall contact frame (tracks.contact_frames) is the wall's.
    """

    def __init__(self, figures: FigureModel, geometry: TableGeometry, resolution: int = WINDOW):
        self.rod_y = figures.rod_y
        self.reach = figures.reach_y + FIGURE_ZONE
        self.geometry = geometry
        self.resolution = resolution

    def near_rod(self, xy: np.ndarray) -> np.ndarray:
        return np.min(np.abs(xy[:, 1:2] - self.rod_y[None]), axis=1) < self.reach

    def contact_frames(self, t: np.ndarray, xy: np.ndarray) -> np.ndarray:
        change, _speed, noise = velocity_change(t, xy, WINDOW)
        return self.sudden_changes(xy, change, noise, contact_frames(self.geometry, t, xy, WINDOW))

    def sudden_changes(self, xy: np.ndarray, change: np.ndarray, noise: float, wall_frames: np.ndarray) -> np.ndarray:
        """contact_frames from the track's velocity_change (change, noise) and wall contact frames, where the caller
        has them already."""
        n = len(xy)
        threshold = max(ROD_CHANGE_FLOOR, ROD_CHANGE_NOISE_SIGMAS * noise)
        if n < 2 * WINDOW or not np.any(change > threshold):
            return np.zeros(n, dtype=bool)
        r = self.resolution
        padded = np.concatenate([np.zeros(r), change, np.zeros(r)])
        peak = change >= windows(padded, 2 * r + 1).max(axis=1)
        # A change whose windows reach a wall contact is the wall's: without the figures' poses nothing says otherwise.
        wall = _spread(wall_frames, r)
        event = peak & (change > threshold) & self.near_rod(xy) & ~wall
        # The frames around the touch: those whose velocity windows both saw it.
        return _spread(event, PEAK_HALF_WIDTH)


class PosedFigures:
    """Contact frames from the figures posed by the joint states, and RodLines' sudden changes wherever they are."""

    def __init__(self, figures: FigureModel, joints: JointTrack, geometry: TableGeometry):
        self.figures, self.joints, self.geometry = figures, joints, geometry
        # The posed rule below tells a figure's touch next to a wall from a bounce, so the rod lines here only catch
        # what the poses cannot see, at a finer resolution: a kicked ball often meets a raised figure 4-5 frames
        # later (by a side wall, or after a foot), and judged a whole window apart that second touch was taken for
        # the kick's, or the wall's, and stayed in the rolling segment. A touch judged twice only cuts a few more
        # frames next to it.
        self.fallback = RodLines(figures, geometry, resolution=PEAK_HALF_WIDTH)

    def gaps(self, t: np.ndarray, xy: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(n,) gap to the nearest figure at each frame, and (n - 1,) the least gap between consecutive frames
        (ball and figures interpolated; samples at least every SWEEP_STEP of figure or ball motion)."""
        n = len(t)
        q = self.joints.at(t)
        at_frames = self.figures.distance(xy, q)
        if n < 2:
            return at_frames, np.zeros(0)
        reach = 0.09  # m: a figure's farthest surface from its rod axis (the sweep's step size only)
        motion = np.max(np.abs(np.diff(q[:, 0::2], axis=0)) + reach * np.abs(np.diff(q[:, 1::2], axis=0)), axis=1)
        motion += np.linalg.norm(np.diff(xy, axis=0), axis=1)
        samples = np.clip(np.ceil(motion / SWEEP_STEP).astype(int), 1, MAX_SWEEP_SAMPLES)
        interval = np.repeat(np.arange(n - 1), samples)
        first = np.concatenate([[0], np.cumsum(samples)[:-1]])
        fraction = (np.arange(len(interval)) - first[interval] + 1) / samples[interval]  # (0, 1]: ends at the next frame
        ts = t[interval] + fraction * (t[interval + 1] - t[interval])
        xys = xy[interval] + fraction[:, None] * (xy[interval + 1] - xy[interval])
        d = self.figures.distance(xys, self.joints.at(ts))
        between = np.minimum(np.minimum.reduceat(d, first), at_frames[:-1])
        return at_frames, between

    def contact_frames(self, t: np.ndarray, xy: np.ndarray) -> np.ndarray:
        at_frames, between = self.gaps(t, xy)
        least = at_frames.copy()
        if len(between):
            least[:-1] = np.minimum(least[:-1], between)
            least[1:] = np.minimum(least[1:], between)
        near = least < FIGURE_ZONE
        change, speed, noise = velocity_change(t, xy, WINDOW)
        dt = float(np.median(np.diff(t))) if len(t) > 1 else 0.0
        # A change whose windows reach a wall contact is the wall's (a bounce spreads over +/- WINDOW frames)
        # unless a figure was close too.
        wall_frames = contact_frames(self.geometry, t, xy, WINDOW)
        wall = _spread(wall_frames, WINDOW)
        near |= (change > CHANGE_WITH_JOINTS) & (least < 0.01 + 1.5 * speed * dt) & (~wall | (least < WALL_OR_FIGURE))
        # The gaps are those of a ball resting on the field. A hard kick sends it flying (8 cm high on the fast
        # physics) into figures raised above the field, which those gaps cannot see, and where the encoders have a
        # gap the figures are not placed at all: a sudden change within a figure's reach of a rod line that is no
        # wall's is a figure's touch whatever the poses say, as without joint states. Left uncut, such a touch
        # bends one rolling segment, and a small deep dent at the rod line absorbs the bend.
        return near | self.fallback.sudden_changes(xy, change, noise, wall_frames)


def for_game(params: dict, joints: JointTrack | None, figures: FigureModel | None = None) -> PosedFigures | RodLines:
    """What tracks.analyse(..., figures=) takes: figures posed by the joint states, or the rod lines without them.
    `figures`: the FigureModel of `params` where the caller has built it already (it builds a MuJoCo model)."""
    figures = figures if figures is not None else FigureModel(params)
    geometry = TableGeometry.from_params(params)
    return PosedFigures(figures, joints, geometry) if joints is not None else RodLines(figures, geometry)
