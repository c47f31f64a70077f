"""Where a figure can show up in the ball plane: one band of y per rod (used by the `auto` colour vote).

A figure is fixed to its rod: it slides along x and turns about the rod's axis, but its y never leaves the
rod's line. The tracker maps every pixel onto the ball-centre plane, so a figure's pixels, which lie higher
than the ball's centre, land farther from the camera's foot than the figure is (parallax), but always at
the same y whatever the rod's slide: for a point at height z and table y, seen from a camera at C, the ray
meets the ball plane at y_b = C_y + (y - C_y) (C_z - z_b) / (C_z - z), which does not depend on x. So a
figure sliding with its rod draws a line of constant y_b inside its rod's band, while a ball rolls in two
dimensions and crosses the rod lines. The figures' sizes and rod positions are foos_sim's (the regulation
table, or a calibrated table's parameter file).

The steel rods themselves are always in front of the ball (a rod's underside is 70 mm up, the ball's top 35
mm), so their image (`rod_mask`) is where the ball is known to be hidden, never where it is. The converse
holds too: nothing on the field can hide a rod, but a figure can (the rod runs through its body) and so can a
hand. A blob that covers a rod's axis (`rod_axis_mask`) is therefore not the ball.

ROS-free: plain numpy and OpenCV.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from foos_core.markers import BALL_CENTRE_HEIGHT
from foos_core.table_params import load_params

from .figure_mask import draw_polyline, fill_convex, project_points


@dataclass(frozen=True)
class RodGeometry:
    """What decides where a hanging figure can be seen: rod lines and a figure's extent (table frame, m)."""

    rod_y: tuple[float, ...]  # y of each rod's axis
    top: float  # height of a figure's head (rod axis + head height)
    half_thickness: float  # half the figure's extent along y (its foot, the thickest part)
    axis_height: float = 0.078  # rod axis above the field
    radius: float = 0.008  # steel rod
    half_length: float = 0.40  # along x, past the side walls: beyond the field is outside the searched region


def rod_geometry(params_file: Optional[str] = None) -> RodGeometry:
    """The rods and figures of foos_sim's table (the nominal one when params_file is None)."""
    tree = load_params(params_file)
    rods, figure = tree["rods"], tree["figure"]
    return RodGeometry(rod_y=tuple(sorted(float(r["y"]) for r in rods["layout"].values())),
                       top=float(rods["axis_height"]) + float(figure["head_height"]),
                       half_thickness=max(float(figure["foot_size"][1]), float(figure["body_size"][1])) / 2,
                       axis_height=float(rods["axis_height"]), radius=float(rods["radius"]),
                       half_length=float(tree["field"]["width"]) / 2 + 0.06)


def camera_centre(projection: np.ndarray) -> np.ndarray:
    """The camera's position (table frame) from its 3x4 projection matrix: the matrix's null vector."""
    _, _, vt = np.linalg.svd(projection)
    centre = vt[-1]
    return centre[:3] / centre[3]


def rod_bands(geometry: RodGeometry, centre: np.ndarray, margin: float = 0.005) -> np.ndarray:
    """(rods, 2) interval of ball-plane y that a hanging figure of each rod covers in this camera's view: the
    parallax of every height from the floor to the head, for the figure's front and back faces, plus margin."""
    cy, cz = float(centre[1]), float(centre[2])
    bands = []
    for y in geometry.rod_y:
        ends = [cy + (face - cy) * (cz - BALL_CENTRE_HEIGHT) / (cz - z)
                for face in (y - geometry.half_thickness, y + geometry.half_thickness) for z in (0.0, geometry.top)]
        bands.append((min(ends) - margin, max(ends) + margin))
    return np.array(bands)


def on_rod_line(y: float, bands: np.ndarray) -> bool:
    return bool(np.any((bands[:, 0] <= y) & (y <= bands[:, 1])))


# The rod's image is filled as convex pieces this long (m): a lens bends a long rod, a short piece stays convex.
_ROD_PIECE = 0.05
_ROD_SECTION = 16  # points around the rod's cross-section


# Steel in OpenCV's 8-bit Lab: grey (a, b near 128) and neither black nor a white highlight's full glare.
STEEL_AB_TOL, STEEL_L = 10, (60, 250)
ROD_SHIFT_MAX, ROD_SHIFT_STEP = 0.008, 0.0005  # m of ball-plane y searched around each rod's nominal image


def fit_rod_shifts(bgr: np.ndarray, region: np.ndarray, geometry: RodGeometry, projection: np.ndarray,
                   distort) -> np.ndarray:
    """Per rod, the shift in y (m) that puts its axis's image on the grey steel seen in this frame.

    The camera's height comes from the tags, and near straight down only from a field-of-view hint: a rod 60 mm
    above the ball plane then lands a pixel off at the far end, a fifth of a small ball's radius. A rod is a long
    grey line on the felt, so its image is found where grey is along the predicted line: the middle of the
    run of shifts whose line lies on steel. A rod not seen (nothing grey along it) gets NaN."""
    height, width = region.shape
    # The axis's line lies on steel for shifts up to a rod radius either side of the true one: search that far
    # past the largest shift, so that the run of shifts on steel is never cut short by the search's end.
    reach = ROD_SHIFT_MAX + 1.5 * geometry.radius
    shifts = np.arange(-reach, reach + 1e-9, ROD_SHIFT_STEP)
    xs = np.arange(-geometry.half_length, geometry.half_length, 0.005)
    found = []
    for y in geometry.rod_y:
        grid_x, grid_y = np.meshgrid(xs, y + shifts)  # (shifts, xs)
        points = np.column_stack([grid_x.ravel(), grid_y.ravel(), np.full(grid_x.size, geometry.axis_height)])
        p = np.round(project_points(projection, distort, points)[0]).astype(int).reshape(len(shifts), len(xs), 2)
        inside = (p[..., 0] >= 0) & (p[..., 0] < width) & (p[..., 1] >= 0) & (p[..., 1] < height)
        p = np.where(inside[..., None], p, 0)
        seen = inside & (region[p[..., 1], p[..., 0]] > 0)
        # Only the sampled pixels are converted to Lab: a whole 1080p frame would cost more than the search.
        lab = cv2.cvtColor(np.ascontiguousarray(bgr[p[..., 1], p[..., 0]]), cv2.COLOR_BGR2Lab).astype(int)
        steel = ((np.abs(lab[..., 1] - 128) <= STEEL_AB_TOL) & (np.abs(lab[..., 2] - 128) <= STEEL_AB_TOL)
                 & (lab[..., 0] >= STEEL_L[0]) & (lab[..., 0] <= STEEL_L[1]))
        on_steel = seen & steel
        count = seen.sum(axis=1)
        score = np.where(count >= 20, on_steel.sum(axis=1) / np.maximum(count, 1), 0.0)
        if score.max() < 0.5:
            found.append(float("nan"))
            continue
        on = np.nonzero(score >= 0.8 * score.max())[0]
        found.append(float(np.clip(shifts[on].mean(), -ROD_SHIFT_MAX, ROD_SHIFT_MAX)))
    return np.array(found)


def rod_mask(geometry: RodGeometry, projection: np.ndarray, distort, image_size: tuple[int, int],
             shifts: Optional[np.ndarray] = None) -> np.ndarray:
    """uint8 image, 255 where a steel rod is seen. projection: 3x4 table -> undistorted pixels (table frame with z
    up from the field); distort: undistorted -> image pixels (N, 2); shifts: per rod, m of y (fit_rod_shifts; a
    rod not seen, NaN, is drawn at its nominal place: it is there, hidden or not).
    A cylinder is the convex hull of its end circles, so each piece's image is the hull of its two circles'
    images."""
    width, height = image_size
    mask = np.zeros((height, width), np.uint8)
    angle = np.linspace(0, 2 * np.pi, _ROD_SECTION, endpoint=False)
    n_pieces = max(1, int(np.ceil(2 * geometry.half_length / _ROD_PIECE)))
    xs = np.linspace(-geometry.half_length, geometry.half_length, n_pieces + 1)
    for i, y in enumerate(geometry.rod_y):
        if shifts is not None and np.isfinite(shifts[i]):
            y += shifts[i]
        ring_y = y + geometry.radius * np.cos(angle)
        ring_z = geometry.axis_height + geometry.radius * np.sin(angle)
        pixels, depth = project_points(projection, distort,
                                       np.array([(x, cy, cz) for x in xs for cy, cz in zip(ring_y, ring_z)]))
        if np.any(depth <= 0):
            continue  # a rod reaching behind the camera: not a view of a table
        pixels = pixels.reshape(len(xs), _ROD_SECTION, 2)
        for a, b in zip(pixels[:-1], pixels[1:]):
            fill_convex(mask, cv2.convexHull(np.concatenate([a, b]).astype(np.float32)))
    return mask


def rod_axis_mask(geometry: RodGeometry, projection: np.ndarray, distort, image_size: tuple[int, int],
                  shifts: Optional[np.ndarray] = None) -> np.ndarray:
    """uint8 image, 255 on the one-pixel line of each rod's axis (same arguments as rod_mask). The axis is the
    middle of the rod's image, a rod radius from either edge, so a placement a pixel off still finds steel there.
    A rod not seen on the steel (NaN shift) is left out: what covers it is not known to be in front of it."""
    width, height = image_size
    mask = np.zeros((height, width), np.uint8)
    xs = np.arange(-geometry.half_length, geometry.half_length + 1e-9, 0.01)
    for i, y in enumerate(geometry.rod_y):
        if shifts is not None:
            if not np.isfinite(shifts[i]):
                continue
            y += shifts[i]
        pixels, depth = project_points(projection, distort,
                                       np.column_stack([xs, np.full_like(xs, y), np.full_like(xs, geometry.axis_height)]))
        if np.any(depth <= 0):
            continue
        draw_polyline(mask, pixels)
    return mask
