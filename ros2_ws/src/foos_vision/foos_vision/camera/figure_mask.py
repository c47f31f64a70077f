"""Where the figures are in the image, from the rod joint positions (/joint_states): the figure mask.

A figure of the ball's colour hanging down is a ball-sized patch of that colour from above, and a ball
touching it merges with it; colour and shape alone cannot tell them apart. An instrumented table (and
every simulator bag) knows the 16 rod joints, so the figures' boxes are known in the table frame: each box
of the foos_sim model is posed with MuJoCo's forward kinematics, its 8 corners are projected with the
camera found from the tag homography, and the convex hull of their images is the figure's footprint (a
box's silhouette is exactly that hull). Pixels under a footprint are not ball evidence.

ROS-free: plain numpy, OpenCV and MuJoCo.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import mujoco
import numpy as np

from foos_core.joints import joint_order, take_joints
from foos_core.markers import BALL_CENTRE_HEIGHT
from foos_core.names import JOINT_NAMES, is_figure_geom
from foos_sim import load_model

from ..errors import VisionError
from .geometry import Lens, PlaneMapping, camera_matrix_for

# Pixels added around each footprint. None: the footprint is filled to sub-pixel precision, and a margin
# eats the visible rim of a ball touching a figure (on the 4 s bench set, 1 px cost 1-2 points of recall
# in four cases and found no more false detections than 0 px; 2 px cost the white 640x480 case 3 points).
MASK_MARGIN_PX = 0
_SUBPIXEL_BITS = 4
# Only the parts of a figure above the ball's top are sure to be in front of a ball they overlap in the
# image; a foot at the ball's own height beside it can be behind it (a ball rolling past a kicked figure's
# foot hid part of the foot's footprint), so the boxes are cut there before projecting.
BALL_TOP = 2 * BALL_CENTRE_HEIGHT
# The 12 edges of a box as pairs of corner indices (corners differ in one sign).
_CORNER_SIGNS = np.array([[sx, sy, sz] for sx in (-1, 1) for sy in (-1, 1) for sz in (-1, 1)], float)


_EDGES = np.array([(i, j) for i in range(8) for j in range(i + 1, 8)
                   if np.sum(_CORNER_SIGNS[i] != _CORNER_SIGNS[j]) == 1])


def clip_above(corners: np.ndarray, z_min: float) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (G, 8, 3 corners) cut to z >= z_min: (G, 20, 3) points and which boxes keep any part. The hull
    of a box's points is its cut part's silhouette: the corners above z_min and where its edges cross z_min;
    the other slots repeat a point inside (the mean of the kept ones), which leaves the hull as it is."""
    z = corners[:, :, 2]
    a, b = corners[:, _EDGES[:, 0]], corners[:, _EDGES[:, 1]]  # (G, 12, 3)
    za, zb = z[:, _EDGES[:, 0]], z[:, _EDGES[:, 1]]
    crosses = (za - z_min) * (zb - z_min) < 0
    s = np.where(crosses, (z_min - za) / np.where(crosses, zb - za, 1.0), 0.0)
    points = np.concatenate([corners, a + s[..., None] * (b - a)], axis=1)
    keep = np.concatenate([z >= z_min, crosses], axis=1)
    count = keep.sum(axis=1)
    inside = (points * keep[..., None]).sum(axis=1) / np.maximum(count, 1)[:, None]
    points = np.where(keep[..., None], points, inside[:, None, :])
    return points, count >= 3


class JointStatesError(VisionError):
    """Joint states that cannot be used (missing joints, nothing finite)."""


class FigureGeometry:
    """The figures' boxes in the table frame for given rod joint positions (foos_sim's model)."""

    def __init__(self, params_file: Optional[str] = None):
        self.model = load_model(params_file)
        self.data = mujoco.MjData(self.model)
        self._qpos = np.array([self.model.joint(n).qposadr[0] for n in JOINT_NAMES])
        names = [self.model.geom(i).name for i in range(self.model.ngeom)]
        self.geoms = np.array([i for i, n in enumerate(names) if is_figure_geom(n)
                               and self.model.geom_type[i] == mujoco.mjtGeom.mjGEOM_BOX])
        if len(self.geoms) == 0:
            raise VisionError("the foos_sim model has no figure boxes (geoms named *_figure*)")
        self._half = self.model.geom_size[self.geoms].copy()  # (G, 3) half extents

    def corners(self, joints: np.ndarray) -> np.ndarray:
        """(G, 8, 3) corners of every figure box, table frame, for the 16 joints in JOINT_NAMES order."""
        self.data.qpos[self._qpos] = joints
        mujoco.mj_kinematics(self.model, self.data)
        centre = self.data.geom_xpos[self.geoms]  # (G, 3)
        rot = self.data.geom_xmat[self.geoms].reshape(-1, 3, 3)
        local = _CORNER_SIGNS[None, :, :] * self._half[:, None, :]  # (G, 8, 3)
        return centre[:, None, :] + np.einsum("gij,gkj->gki", rot, local)


def projection_from_mapping(mapping: PlaneMapping, image_size: tuple[int, int], camera_matrix: Optional[np.ndarray],
                            fovy_hint: float = 50.0) -> np.ndarray:
    """3x4 matrix taking table points (x, y, z) to undistorted pixels, from the ball-plane homography and the
    intrinsics (given, or the focal length estimated from the homography, or the field-of-view hint)."""
    h = mapping.table_to_image
    # A straight-down view cannot reveal its focal length; the heights the mask needs (a figure is 10 cm
    # tall, the camera about 1 m up) make a few per cent of error in the hint a fraction of a pixel.
    k = camera_matrix_for(h, image_size, camera_matrix, fovy_hint)
    m = np.linalg.inv(k) @ h
    lam = 1.0 / np.linalg.norm(m[:, 0])
    if m[2, 2] < 0:
        lam = -lam  # the plane is in front of the camera
    r1, r2, t = lam * m[:, 0], lam * m[:, 1], lam * m[:, 2]
    r1 /= np.linalg.norm(r1)
    r2 = r2 - (r2 @ r1) * r1
    r2 /= np.linalg.norm(r2)
    r3 = np.cross(r1, r2)
    if -(r3 @ t) < 0:
        r3 = -r3  # the camera is above the table (+z), whatever the image's handedness
    # Table point (x, y, z) -> plane coordinates (x, y, z - ball-centre height).
    shift = np.eye(4)
    shift[2, 3] = -BALL_CENTRE_HEIGHT
    return k @ np.column_stack([r1, r2, r3, t]) @ shift


def project_points(projection: np.ndarray, distort, points: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Table points (N, 3) to image pixels (N, 2) through a 3x4 projection (projection_from_mapping) and a lens's
    distort, and their depth (N,): a point at depth <= 0 is behind the camera and its pixel means nothing."""
    homogeneous = np.concatenate([points, np.ones((len(points), 1))], axis=1) @ projection.T
    depth = homogeneous[:, 2]
    return distort(homogeneous[:, :2] / np.where(np.abs(depth) < 1e-9, 1e-9, depth)[:, None]), depth


def fill_convex(mask: np.ndarray, hull: np.ndarray) -> None:
    """Fill a convex polygon given in float pixel coordinates into mask (255), to 1/16 px."""
    scale = float(1 << _SUBPIXEL_BITS)
    cv2.fillConvexPoly(mask, np.round(hull * scale).astype(np.int32), 255, cv2.LINE_8, _SUBPIXEL_BITS)


def draw_polyline(mask: np.ndarray, points: np.ndarray) -> None:
    """Draw an open one-pixel line through float pixel coordinates into mask (255), to 1/16 px."""
    scale = float(1 << _SUBPIXEL_BITS)
    cv2.polylines(mask, [np.round(points * scale).astype(np.int32)], False, 255, 1, cv2.LINE_8, _SUBPIXEL_BITS)


class FigureMasker:
    """The image footprint of every figure for given joint positions, under one camera."""

    def __init__(self, geometry: FigureGeometry, projection: np.ndarray, lens: Lens, image_size: tuple[int, int],
                 margin_px: int = MASK_MARGIN_PX):
        self.geometry = geometry
        self.projection = projection
        self.lens = lens
        self.width, self.height = image_size
        self.margin_px = margin_px

    def footprints(self, joints: np.ndarray, below: bool = False) -> list[np.ndarray]:
        """One convex polygon (pixels, distorted image) per figure box, of its part above the ball's top (below:
        of its part below, a foot at the ball's height)."""
        corners = self.geometry.corners(joints)
        if below:
            # The part below a height is the part above it with z turned over.
            flip = np.array([1.0, 1.0, -1.0])
            points, kept = clip_above(corners * flip, -BALL_TOP)
            points = points * flip
        else:
            points, kept = clip_above(corners, BALL_TOP)
        points = points[kept]
        g, n = points.shape[:2]
        pixels, depth = project_points(self.projection, self.lens.distort, points.reshape(-1, 3))
        pixels = pixels.reshape(g, n, 2).astype(np.float32)
        in_front = np.all(depth.reshape(g, n) > 0, axis=1)  # a box behind the camera is not in the image
        return [cv2.convexHull(p) for p, ok in zip(pixels, in_front) if ok]

    def mask(self, joints: np.ndarray, below: bool = False) -> np.ndarray:
        """uint8 image, 255 under a figure (plus the margin); below: under the figures' parts below the ball's top."""
        mask = np.zeros((self.height, self.width), np.uint8)
        for hull in self.footprints(joints, below):
            fill_convex(mask, hull)
        if self.margin_px > 0:
            size = 2 * self.margin_px + 1
            mask = cv2.dilate(mask, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (size, size)))
        return mask


@dataclass
class JointTrack:
    """Rod joint positions over time (16 columns in JOINT_NAMES order), looked up at frame times."""

    t: np.ndarray  # (N,) s, sorted
    position: np.ndarray  # (N, 16)
    max_gap: float = 0.1  # s: farther than this from a reading, a frame gets no mask

    def at(self, t: float) -> Optional[np.ndarray]:
        """Linear interpolation between the readings around t (None outside the readings or across a gap)."""
        n = len(self.t)
        i = int(np.searchsorted(self.t, t))
        if i < n and self.t[i] == t:
            return self.position[i]
        if i == 0:
            return self.position[0] if self.t[0] - t <= self.max_gap / 2 else None
        if i == n:
            return self.position[-1] if t - self.t[-1] <= self.max_gap / 2 else None
        t0, t1 = self.t[i - 1], self.t[i]
        if t1 - t0 > self.max_gap:
            return None
        w = (t - t0) / (t1 - t0)
        return (1 - w) * self.position[i - 1] + w * self.position[i]

    def covers(self, t0: float, t1: float) -> bool:
        return len(self.t) > 0 and self.t[0] <= t1 and self.t[-1] >= t0


def joint_track(t: np.ndarray, names: list[str], position: np.ndarray, source: str) -> JointTrack:
    """Columns reordered to JOINT_NAMES; rows with a NaN dropped. JointStatesError when unusable."""
    order = joint_order(names, allow_missing=True)
    missing = [JOINT_NAMES[i] for i in np.flatnonzero(order < 0)]
    if missing:
        raise JointStatesError(f"{source}: joint states lack {len(missing)} of the 16 rod joints "
                               f"(e.g. {missing[0]}); the figure mask needs all of them")
    position = take_joints(position, order)
    t = np.asarray(t, float)
    good = np.isfinite(t) & np.all(np.isfinite(position), axis=1)
    if not np.any(good):
        raise JointStatesError(f"{source}: no joint-state message has finite positions for all 16 rod joints")
    order = np.argsort(t[good], kind="stable")
    return JointTrack(t[good][order], position[good][order])
