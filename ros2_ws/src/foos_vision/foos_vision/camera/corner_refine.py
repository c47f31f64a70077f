"""Field corners clicked to a pixel or two, fitted to the table's edges seen in the image.

Two pixels of error at each corner move the ball-plane mapping by about a pixel in the field's middle, several
millimetres at 640x480. The table's walls are long straight edges, each found to a fraction of a pixel near
where the given corners put it, and the corners and the focal length are then moved (least squares, a
pixel-sized prior on the clicks) until the camera they imply puts every edge where it was seen. Per wall, the
edges looked for are:
- the surface's edge (felt against the wall's inner face, z = 0), where the camera is on the field's side of
  the wall and sees that face; the goal mouth is left out;
- the wall's inner top edge (z = the wall's height), the step onto the wall top's grey. From behind an end wall
  the surface's edge is behind the wall, and in an oblique view the goalie rod can lie right over the far end's
  surface edge, a steel edge parallel to it: the top edges place those ends, and tell the focal length.
The corners' own neighbourhoods and wherever a rod's image crosses the search are left out, and the points
found along an edge must lie on one line. With no edge found, or a fit the edges disagree with, the corners
stay as given.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from .geometry import surface_homography
from .rod_lines import RodGeometry, camera_centre

SEARCH_PX = 6.0  # a fit that moves a corner farther than this (undistorted px) from where it was given is refused
STEP_PX = 0.25  # profile sampling across the edge
LEVEL_PX = 1.5  # the levels either side of an edge are read this far from it
SAMPLES_PER_SIDE = 48
CORNER_MARGIN = 0.06  # fraction of a wall left out at each end: the corner's own clutter (posts, shadows)
MOUTH_MARGIN = 0.03  # m beyond each goal post left out of an end wall's surface edge
MIN_CONTRAST = 6.0  # grey levels per px: weaker is no edge (felt against a wall of its own shade)
MIN_INLIERS = 0.4  # share of a wall's samples on its line, at least
MAX_LINE_RMS_PX = 0.6  # a wall whose edge points lie farther off one line is curved (an uncorrected lens) or clutter
# A rod's image is wider than its steel by blur and its shaded underside, and the first search is a couple of
# pixels off where the given corners are: the steel's edge, parallel to an end wall, would pass for the wall's.
ROD_MARGIN_PX = 3.0
TOP_MATCH = 0.4  # a step onto a wall's top ends at least this much nearer the top's grey than it starts
EDGE_OUTLIER_PX = 1.0  # an edge whose points lie this far off the fit (median) was found on something else
EDGE_SIGMA_PX = 0.3  # how well an edge point is found
CLICK_SIGMA_PX = 2.0  # how well a corner is given
FOCAL_SIGMA = 0.5  # how well the corners' focal length is known (relative)
GAUSS_NEWTON_STEPS = 8
# The edges are looked for this far (undistorted px) either side of where the given corners put them, and again
# nearer where each fit puts them: the last fit's edges are a pixel off at most.
SEARCH_ROUNDS_PX = (6.0, 3.0, 3.0)


@dataclass
class CornerRefinement:
    pixels: np.ndarray  # (4, 2) corners in the (distorted) image
    edges_used: int  # edges the corners were fitted to (a surface and a top edge per wall: 8 at most); 0: as given
    moved_px: float  # the largest move of a corner
    edge_rms_px: float = float("nan")  # the edge points' distance from where the fitted corners put their edges


@dataclass
class _Edge:
    start: np.ndarray  # a 3D line of the table (table frame, m) ...
    end: np.ndarray
    points: np.ndarray  # ... and the (undistorted) pixels found on it


class _Table:
    """The table's edges in the frame of the field's corners, and the camera a set of corners implies."""

    def __init__(self, half_width: float, half_length: float, wall_height: float, wall_thickness: float,
                 camera_matrix: np.ndarray, image_size: tuple[int, int]):
        self.half_width, self.half_length = half_width, half_length
        self.wall_height, self.wall_thickness = wall_height, wall_thickness
        self.camera_matrix, self.image_size = camera_matrix, image_size
        self.corners = np.array([(-half_width, -half_length), (half_width, -half_length), (half_width, half_length),
                                 (-half_width, half_length)])

    def projection(self, corners: np.ndarray, focal_scale: float = 1.0) -> np.ndarray:
        """3x4: table points -> undistorted pixels, for the surface's corners at these pixels: exactly their
        homography on the surface, and the camera's rotation (its focal length scaled by focal_scale) for height."""
        plane = np.linalg.inv(surface_homography(corners, self.half_width, self.half_length))
        camera_matrix = self.camera_matrix.copy()
        camera_matrix[0, 0] *= focal_scale
        camera_matrix[1, 1] *= focal_scale
        rotated = np.linalg.inv(camera_matrix) @ plane
        if rotated[2, 2] < 0:
            plane, rotated = -plane, -rotated  # the surface is in front of the camera
        lengths = np.linalg.norm(rotated[:, :2], axis=0)
        up = np.cross(rotated[:, 0] / lengths[0], rotated[:, 1] / lengths[1])
        up *= lengths.mean() / np.linalg.norm(up)
        projection = np.column_stack([plane[:, 0], plane[:, 1], camera_matrix @ up, plane[:, 2]])
        if camera_centre(projection)[2] < 0:
            projection[:, 2] *= -1  # the camera is above the table, whatever the image's handedness
        return projection


def refine_field_corners(bgr: np.ndarray, given: np.ndarray, lens, camera_matrix: np.ndarray, focal_known: bool,
                         rods: RodGeometry, half_width: float, half_length: float, goal_half_width: float,
                         wall_height: float, wall_thickness: float) -> CornerRefinement:
    """given: (4, 2) image pixels in the order (-x,-y), (+x,-y), (+x,+y), (-x,+y); lens: geometry.Lens;
    camera_matrix: the camera's, focal_known when it is the intrinsics' or revealed by the corners (not a hint)."""
    given = np.asarray(given, float)
    table = _Table(half_width, half_length, wall_height, wall_thickness, camera_matrix, (bgr.shape[1], bgr.shape[0]))
    gray = cv2.GaussianBlur(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY).astype(np.float32), (0, 0), 0.7)
    start = lens.undistort(given)
    fitted, focal_scale, edges = start, 1.0, []
    for round_index, search_px in enumerate(SEARCH_ROUNDS_PX):
        # Each round looks for the edges where the last one's corners and focal length put them. With a focal length
        # that is only the hint's, the first trusts the surface's edges where it sees them: a wall's top edge, off
        # the surface, is then several pixels from where it is predicted.
        edges = _find_edges(gray, table, table.projection(fitted, focal_scale), lens, rods, goal_half_width,
                            search_px, tops_everywhere=focal_known or round_index > 0)
        if not edges:
            return CornerRefinement(given, 0, 0.0)
        fitted, focal_scale = _fit_corners(table, start, edges)
        # An edge the others disagree with (a step found on something else) is left out, once.
        offsets = [abs(np.median(r)) for r in _edge_residuals(table, fitted, focal_scale, edges, per_edge=True)]
        if max(offsets) > EDGE_OUTLIER_PX and len(edges) > 2:
            del edges[int(np.argmax(offsets))]
            fitted, focal_scale = _fit_corners(table, start, edges)
        if not np.all(np.isfinite(fitted)) or np.max(np.linalg.norm(fitted - start, axis=1)) > SEARCH_PX:
            return CornerRefinement(given, 0, 0.0)
    residual = _edge_residuals(table, fitted, focal_scale, edges)
    if np.sqrt(np.mean(residual ** 2)) > MAX_LINE_RMS_PX:
        return CornerRefinement(given, 0, 0.0)
    pixels = lens.distort(fitted)
    return CornerRefinement(pixels, len(edges), float(np.max(np.linalg.norm(pixels - given, axis=1))),
                            float(np.sqrt(np.mean(residual ** 2))))


def _find_edges(gray: np.ndarray, table: _Table, projection: np.ndarray, lens, rods: RodGeometry,
                goal_half_width: float, search_px: float, tops_everywhere: bool) -> list[_Edge]:
    """Per wall, its surface edge where the camera sees its inner face, and its inner top edge (with
    tops_everywhere, else only where the surface edge is not found); those hidden or not found are left out."""
    camera = camera_centre(projection)
    edges = []
    for i in range(4):
        a, b = table.corners[i], table.corners[(i + 1) % 4]
        surface = None
        if _inner_face_seen(a, b, camera[:2]):
            mouth = goal_half_width + MOUTH_MARGIN if abs(a[0] - b[0]) > abs(a[1] - b[1]) else 0.0
            surface = _find_edge(gray, np.append(a, 0.0), np.append(b, 0.0), projection, lens, rods, mouth, search_px)
            edges.append(surface)
        if table.wall_height > 0 and (tops_everywhere or surface is None):
            edges.append(_find_edge(gray, np.append(a, table.wall_height), np.append(b, table.wall_height), projection,
                                    lens, rods, 0.0, search_px, table.wall_thickness))
    return [edge for edge in edges if edge is not None]


def _inner_face_seen(a: np.ndarray, b: np.ndarray, camera_xy: np.ndarray) -> bool:
    """The camera is on the field's side of the wall from a to b (its inner face, and the surface's edge, in view)."""
    along = b - a
    inward = np.array([-along[1], along[0]])  # the corners go round counter-clockwise: left of a -> b is inside
    return float(np.dot(camera_xy - a, inward)) > 0.0


def _fit_corners(table: _Table, start: np.ndarray, edges: list[_Edge],
                 focal_sigma: float = FOCAL_SIGMA) -> tuple[np.ndarray, float]:
    """Gauss-Newton on the 8 corner coordinates and the focal length's scale: edge points onto their projected
    lines, corners near start. The focal length matters to the walls' top edges only; four corners off by a pixel
    or two make it 10 % off in an oblique view, and the top edges then pull the corners off as far."""
    def residuals(flat: np.ndarray) -> np.ndarray:
        return np.concatenate([_edge_residuals(table, flat[:8].reshape(4, 2), flat[8], edges) / EDGE_SIGMA_PX,
                               (flat[:8] - start.ravel()) / CLICK_SIGMA_PX, [(flat[8] - 1.0) / focal_sigma]])

    flat = np.append(start.ravel(), 1.0)
    r = residuals(flat)
    for _ in range(GAUSS_NEWTON_STEPS):
        jacobian = np.empty((len(r), len(flat)))
        for k in range(len(flat)):
            probe = flat.copy()
            probe[k] += 1e-4
            jacobian[:, k] = (residuals(probe) - r) / 1e-4
        step = np.linalg.lstsq(jacobian, -r, rcond=None)[0]
        # A full Gauss-Newton step can overshoot (the edges' projection is not linear in the corners): halve it
        # until the fit improves.
        for _ in range(8):
            moved = residuals(flat + step)
            if moved @ moved < r @ r:
                break
            step /= 2
        else:
            break
        flat, r = flat + step, moved
        if np.max(np.abs(step[:8])) < 1e-3:
            break
    return flat[:8].reshape(4, 2), float(flat[8])


def _edge_residuals(table: _Table, corners: np.ndarray, focal_scale: float, edges: list[_Edge],
                    per_edge: bool = False):
    """Signed distances (px) of each edge's points from its 3D line as these corners' camera projects it: one
    array, or a list of one per edge."""
    projection = table.projection(corners, focal_scale)
    out = []
    for edge in edges:
        a, b = _project(projection, np.array([edge.start, edge.end]))
        direction = (b - a) / np.linalg.norm(b - a)
        out.append((edge.points - a) @ np.array([-direction[1], direction[0]]))
    return out if per_edge else np.concatenate(out)


def _find_edge(gray: np.ndarray, a: np.ndarray, b: np.ndarray, projection: np.ndarray, lens, rods: RodGeometry,
               mouth_half_width: float, search_px: float, top_width: Optional[float] = None) -> Optional[_Edge]:
    """The points of the 3D line a-b, a wall's edge at its height (its middle part, less |x| < mouth_half_width),
    found as a straight step in the image near where the projection puts it, or None. The step taken is the
    strongest; for a wall's inner top edge (top_width: the wall's thickness), the first going outward onto the
    wall top's grey."""
    s = np.linspace(CORNER_MARGIN, 1.0 - CORNER_MARGIN, SAMPLES_PER_SIDE)
    points = a + s[:, None] * (b - a)
    points = points[np.abs(points[:, 0]) >= mouth_half_width]
    samples = len(points)
    centre = _project(projection, points)
    # Across the edge, outward (from the field toward the wall), in the image.
    outward = np.array([b[1] - a[1], a[0] - b[0], 0.0])  # right of a -> b: the corners go round counter-clockwise
    outward /= np.linalg.norm(outward)
    normal = _project(projection, points + 1e-3 * outward) - centre
    normal /= np.linalg.norm(normal, axis=1, keepdims=True)
    clear = ~_rod_in_search(points, centre, normal, projection, rods, search_px)
    points, centre, normal = points[clear], centre[clear], normal[clear]
    if len(points) < max(8, MIN_INLIERS * samples):
        return None
    offsets = np.arange(-search_px - LEVEL_PX, search_px + LEVEL_PX + 1e-9, STEP_PX)
    across = centre[:, None, :] + offsets[None, :, None] * normal[:, None, :]  # (n, m, 2) undistorted
    image = lens.distort(across.reshape(-1, 2)).reshape(across.shape).astype(np.float32)
    profiles = cv2.remap(gray, image[..., 0], image[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    gradient = np.gradient(profiles, STEP_PX, axis=1)
    gradient[:, np.abs(offsets) > search_px] = 0.0
    rows = np.arange(len(gradient))
    if top_width is not None:
        peak = _onto_wall_top(gray, profiles, gradient, points, outward, top_width, projection, lens)
        rows = rows[peak >= 0]
    else:
        peak = np.argmax(np.abs(gradient), axis=1)
    if len(rows) < max(8, MIN_INLIERS * samples):
        return None
    # A wall's edge is one sign of gradient all along it: the sign most samples' step has is this edge's, and a
    # sample whose step has the other sign saw something else (a figure).
    sign = np.sign(np.median(gradient[rows, peak[rows]]))
    rows = rows[gradient[rows, peak[rows]] * sign >= MIN_CONTRAST]
    where = _step_positions(profiles[rows] * sign, offsets, offsets[peak[rows]], search_px)
    found = np.isfinite(where)
    rows, where = rows[found], where[found]
    if len(rows) < max(8, MIN_INLIERS * samples):
        return None
    inliers = _on_one_line(centre[rows] + where[:, None] * normal[rows])
    if inliers is None or len(inliers) < max(8, MIN_INLIERS * samples):
        return None
    return _Edge(a, b, inliers)


def _onto_wall_top(gray: np.ndarray, profiles: np.ndarray, gradient: np.ndarray, points: np.ndarray,
                   outward: np.ndarray, top_width: float, projection: np.ndarray, lens) -> np.ndarray:
    """Per profile, the index of the first strong step going outward that ends on the wall top's grey (-1: none).
    A wall's top is a band with an edge on either side, a few pixels apart seen from afar, and inside it a rod's
    shaded underside or its shadow can make a step as strong: the inner top edge is the one into the band."""
    across = [points + outward * top_width * share for share in (0.3, 0.5, 0.7)]
    pixels = np.stack([lens.distort(_project(projection, p)) for p in across], axis=1).astype(np.float32)
    top_grey = np.median(cv2.remap(gray, pixels[..., 0], pixels[..., 1], cv2.INTER_LINEAR,
                                   borderMode=cv2.BORDER_REPLICATE), axis=1)[:, None]
    magnitude = np.abs(gradient)
    strong = magnitude >= np.maximum(MIN_CONTRAST, 0.3 * magnitude.max(axis=1, keepdims=True))
    strong[:, 1:-1] &= (magnitude[:, 1:-1] >= magnitude[:, :-2]) & (magnitude[:, 1:-1] >= magnitude[:, 2:])
    level = int(round(LEVEL_PX / STEP_PX))
    index = np.arange(profiles.shape[1])
    inner = profiles[:, np.clip(index - level, 0, len(index) - 1)]
    outer = profiles[:, np.clip(index + level, 0, len(index) - 1)]
    strong &= np.abs(outer - top_grey) < TOP_MATCH * np.abs(inner - top_grey)
    first = np.argmax(strong, axis=1)
    return np.where(strong[np.arange(len(first)), first], first, -1)


def _step_positions(profiles: np.ndarray, offsets: np.ndarray, start: np.ndarray, search_px: float) -> np.ndarray:
    """Per profile, where its rising step crosses halfway between its levels LEVEL_PX either side of it (nan where
    it does not, near start). The strongest gradient of a sharp edge sampled by whole pixels lies up to half a
    pixel off the edge (0.35 px outward on the renders); a step that is blurred symmetrically crosses its
    mid-level at the edge."""
    rows = np.arange(len(profiles))
    last = profiles.shape[1] - 1

    def at(position: np.ndarray) -> np.ndarray:  # the profiles, linearly interpolated
        index = np.clip((position - offsets[0]) / STEP_PX, 0, last)
        low = np.minimum(np.floor(index).astype(int), last - 1)
        share = index - low
        return profiles[rows, low] * (1 - share) + profiles[rows, low + 1] * share

    reach = int(round(1.0 / STEP_PX))  # the crossing is looked for within a pixel of the last position
    window = np.arange(-reach, reach + 1)
    position = np.asarray(start, float).copy()
    valid = np.ones(len(rows), bool)
    for _ in range(3):
        low, high = at(position - LEVEL_PX), at(position + LEVEL_PX)
        valid &= high - low >= MIN_CONTRAST * STEP_PX
        centre = np.round((position - offsets[0]) / STEP_PX).astype(int)
        index = np.clip(centre[:, None] + window[None, :], 0, last)
        level = profiles[rows[:, None], index] - ((low + high) / 2)[:, None]
        crossing = (level[:, :-1] < 0) & (level[:, 1:] >= 0)
        valid &= crossing.any(axis=1)
        # The crossing nearest the last position.
        distance = np.where(crossing, np.abs(window[:-1] + 0.5)[None, :], np.inf)
        k = np.argmin(distance, axis=1)
        before, after = level[rows, k], level[rows, k + 1]
        fraction = np.where(after > before, -before / np.where(after > before, after - before, 1.0), 0.0)
        position = offsets[index[rows, k]] + fraction * STEP_PX
    valid &= np.abs(position) <= search_px
    return np.where(valid, position, np.nan)


def _rod_in_search(points: np.ndarray, centre: np.ndarray, normal: np.ndarray, projection: np.ndarray,
                   rods: RodGeometry, search_px: float) -> np.ndarray:
    """Per sample: a rod's image (its axis line, widened by its radius and ROD_MARGIN_PX) meets the segment
    searched across the edge."""
    ends = (centre - search_px * normal, centre + search_px * normal)
    hit = np.zeros(len(points), bool)
    for rod_y in rods.rod_y:
        axis = np.column_stack([points[:, 0], np.full(len(points), rod_y), np.full(len(points), rods.axis_height)])
        a = _project(projection, axis - (0.05, 0, 0))
        b = _project(projection, axis + (0.05, 0, 0))
        direction = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
        across = np.column_stack([-direction[:, 1], direction[:, 0]])
        # The rod's apparent half-width: its radius seen across its axis, at its depth.
        middle = _project(projection, axis)
        half_width = np.max([np.linalg.norm(_project(projection, axis + offset) - middle, axis=1)
                             for offset in ((0, rods.radius, 0), (0, 0, rods.radius))], axis=0) + ROD_MARGIN_PX
        d0 = np.sum((ends[0] - a) * across, axis=1)
        d1 = np.sum((ends[1] - a) * across, axis=1)
        hit |= (np.minimum(d0, d1) < half_width) & (np.maximum(d0, d1) > -half_width)
    return hit


def _on_one_line(points: np.ndarray) -> Optional[np.ndarray]:
    """The points that lie on one line (total least squares, outliers dropped), or None when they do not."""
    keep = np.ones(len(points), bool)
    for _ in range(4):
        line = _fit_line(points[keep])
        distance = np.abs(points @ line[:2] - line[2])
        spread = 1.4826 * np.median(distance[keep])
        new_keep = distance <= max(0.5, 3.0 * spread)
        if np.array_equal(new_keep, keep) or new_keep.sum() < 2:
            break
        keep = new_keep
    line = _fit_line(points[keep])
    rms = float(np.sqrt(np.mean((points[keep] @ line[:2] - line[2]) ** 2)))
    return points[keep] if rms <= MAX_LINE_RMS_PX else None


def _fit_line(points: np.ndarray) -> np.ndarray:
    """Total least squares: the line (n, c) with n . p = c nearest the points."""
    mean = points.mean(axis=0)
    _, _, vt = np.linalg.svd(points - mean)
    normal = vt[1]
    return np.array([normal[0], normal[1], float(normal @ mean)])


def _project(projection: np.ndarray, points: np.ndarray) -> np.ndarray:
    """Table points (N, 3) to undistorted pixels."""
    homogeneous = np.column_stack([np.asarray(points, float), np.ones(len(points))]) @ projection.T
    return homogeneous[:, :2] / homogeneous[:, 2:]


def fit_corners_to_lines(start: np.ndarray, lines: list[tuple[np.ndarray, np.ndarray, np.ndarray]],
                         camera_matrix: np.ndarray, image_size: tuple[int, int], half_width: float, half_length: float,
                         wall_height: float, wall_thickness: float,
                         focal_sigma: float = FOCAL_SIGMA) -> tuple[np.ndarray, float, list[np.ndarray]]:
    """The corners (undistorted px) whose camera puts each 3D line (start, end, table frame m) through the pixels
    found on it (undistorted), from start: (corners, focal scale, per line the points' signed distances, px).
    focal_sigma: how well camera_matrix's focal length is known (relative).
    field_auto uses it for the felt's outline, whose near end is a wall's top edge where the wall hides the surface."""
    table = _Table(half_width, half_length, wall_height, wall_thickness, camera_matrix, image_size)
    edges = [_Edge(np.asarray(a, float), np.asarray(b, float), np.asarray(p, float)) for a, b, p in lines]
    corners, focal_scale = _fit_corners(table, np.asarray(start, float), edges, focal_sigma)
    return corners, focal_scale, _edge_residuals(table, corners, focal_scale, edges, per_edge=True)


def camera_of_corners(corners: np.ndarray, camera_matrix: np.ndarray, image_size: tuple[int, int], half_width: float,
                      half_length: float) -> np.ndarray:
    """The camera centre (table frame, m) the field's corners (undistorted px) imply with this camera matrix."""
    table = _Table(half_width, half_length, 0.0, 0.0, camera_matrix, image_size)
    return camera_centre(table.projection(np.asarray(corners, float)))


def wall_faces_seen(camera_xyz: np.ndarray, half_width: float, half_length: float) -> list[bool]:
    """Per wall from corner i to i + 1 (CORNER_ORDER), whether the camera sees its inner face (and the surface's
    edge along it)."""
    corners = np.array([(-half_width, -half_length), (half_width, -half_length), (half_width, half_length),
                        (-half_width, half_length)])
    return [_inner_face_seen(corners[i], corners[(i + 1) % 4], np.asarray(camera_xyz)[:2]) for i in range(4)]
