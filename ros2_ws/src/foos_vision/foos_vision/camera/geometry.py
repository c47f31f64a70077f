"""From tag detections to a mapping between image pixels and the ball-centre plane of the table.

Tags are located by their centres (the intersection of their diagonals, exact under perspective), so
a tag's rotation on the table does not matter. With all tags in one plane at height z_t a homography
maps the image to that plane; when z_t differs from the ball-centre height the camera centre, found
from the homography and the intrinsics (given, or a focal length estimated from the homography
itself), moves each point along its viewing ray to the ball-centre plane. Tags at several heights
give a full projection matrix (DLT) and need no intrinsics at all. The field's four corners (fit_field_corners)
are a plane at the surface, z = 0, moved up to the ball plane the same way.
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Optional

import cv2
import numpy as np

from foos_core.camera_model import Intrinsics
from foos_core.markers import BALL_CENTRE_HEIGHT, MarkerLayout

from ..errors import MarkersError
from .field_corners import FieldCornersError

MIN_TAGS = 4
MAX_TAG_RESIDUAL = 0.010  # m; worse than this and the markers file does not describe the table filmed
CONSISTENT_TAGS = 0.002  # m RMS; above it, a tag that disagrees with the others is looked for
# A refit looks for each tag within this many of the largest tag's sides (plus TAG_CROP_PAD px) of where it was last
# seen (TagLocator.locate); a tag that moved further sends it back to the whole frame.
TAG_CROP_MARGIN, TAG_CROP_PAD = 1.0, 8.0
TAG_WHOLE_EVERY = 10  # calls of TagLocator.locate: the whole frame is searched again (a tag hidden before may show)


def tag_centre(corners: np.ndarray) -> np.ndarray:
    """Intersection of a quad's diagonals (the projected centre of a square, unlike the corners' mean)."""
    p0, p1, p2, p3 = corners.reshape(4, 2).astype(float)
    d1, d2 = p2 - p0, p3 - p1
    denom = d1[0] * d2[1] - d1[1] * d2[0]
    if abs(denom) < 1e-9:
        return corners.reshape(4, 2).mean(axis=0)
    s = ((p1[0] - p0[0]) * d2[1] - (p1[1] - p0[1]) * d2[0]) / denom
    return p0 + s * d1


class Lens:
    """Undistortion of points (not images: the tracker only needs a few points per frame). "Undistorted"
    pixels are those of a pinhole with the same camera matrix; a fisheye lens (cv2.fisheye) maps to them
    and back with cv2.fisheye.undistortPoints / distortPoints."""

    def __init__(self, intrinsics: Optional[Intrinsics]):
        self.intrinsics = intrinsics
        # A fisheye with k = 0 is still no pinhole (r = f theta, not f tan theta).
        self.active = intrinsics is not None and (intrinsics.fisheye or bool(np.any(intrinsics.dist_coeffs)))

    def undistort(self, pixels: np.ndarray) -> np.ndarray:
        pixels = np.asarray(pixels, float).reshape(-1, 2)
        if not self.active or len(pixels) == 0:
            return pixels
        k, d = self.intrinsics.camera_matrix, self.intrinsics.dist_coeffs
        criteria = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-6)
        if self.intrinsics.fisheye:
            out = cv2.fisheye.undistortPoints(pixels.reshape(-1, 1, 2), k, d, R=np.eye(3), P=k, criteria=criteria)
        else:
            out = cv2.undistortPoints(pixels.reshape(-1, 1, 2), k, d, R=None, P=k, criteria=criteria)
        return out.reshape(-1, 2)

    def distort(self, pixels: np.ndarray) -> np.ndarray:
        pixels = np.asarray(pixels, float).reshape(-1, 2)
        if not self.active or len(pixels) == 0:
            return pixels
        k, d = self.intrinsics.camera_matrix, self.intrinsics.dist_coeffs
        normalised = (pixels - k[:2, 2]) / np.diag(k)[:2]
        if self.intrinsics.fisheye:
            return cv2.fisheye.distortPoints(normalised.reshape(-1, 1, 2), k, d).reshape(-1, 2)
        coefficients = np.ravel(d)
        if len(coefficients) <= 5 and k[0, 1] == 0.0:
            # OpenCV's model (k1, k2, p1, p2, k3), in numpy: cv2.projectPoints takes 0.6 us a point, and placing
            # the rods sends 100k points through the lens (equal to cv2's to 1e-9 px, tested).
            k1, k2, p1, p2, k3 = np.pad(coefficients, (0, 5 - len(coefficients)))
            x, y = normalised[:, 0], normalised[:, 1]
            r2 = x * x + y * y
            radial = 1.0 + r2 * (k1 + r2 * (k2 + r2 * k3))
            xd = x * radial + 2.0 * p1 * x * y + p2 * (r2 + 2.0 * x * x)
            yd = y * radial + p1 * (r2 + 2.0 * y * y) + 2.0 * p2 * x * y
            return np.column_stack([k[0, 0] * xd + k[0, 2], k[1, 1] * yd + k[1, 2]])
        points = np.concatenate([normalised, np.ones((len(pixels), 1))], axis=1)
        out, _ = cv2.projectPoints(points.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
        return out.reshape(-1, 2)


@dataclass
class PlaneMapping:
    """Undistorted pixels <-> (x, y) on the ball-centre plane, z = BALL_CENTRE_HEIGHT."""

    image_to_table: np.ndarray  # 3x3
    table_to_image: np.ndarray  # 3x3
    residual_m: float  # RMS of the tag centres against the markers file, m
    tags_used: int
    camera_height: float  # m above the ball-centre plane (estimated; nan where not needed)
    dropped: dict = None  # tag id -> its disagreement with the others (m), for tags left out of the fit

    def to_table(self, pixels: np.ndarray) -> np.ndarray:
        return cv2.perspectiveTransform(np.asarray(pixels, float).reshape(-1, 1, 2), self.image_to_table).reshape(-1, 2)

    def to_image(self, xy: np.ndarray) -> np.ndarray:
        return cv2.perspectiveTransform(np.asarray(xy, float).reshape(-1, 1, 2), self.table_to_image).reshape(-1, 2)

    def pixels_per_metre(self, xy: np.ndarray) -> float:
        """Local scale of the image at a table point (geometric mean of the two axes)."""
        xy = np.asarray(xy, float).reshape(2)
        h = 1e-3
        p = self.to_image(np.array([xy, xy + (h, 0), xy + (0, h)]))
        jac = np.stack([(p[1] - p[0]) / h, (p[2] - p[0]) / h], axis=1)
        return math.sqrt(abs(np.linalg.det(jac)))


MIN_FOVY_DEG = 10.0  # narrowest plausible vertical field of view, for the focal length a homography gives
# The field's corners reveal the focal length only where moving one corner coordinate by CORNER_PROBE_PX changes
# it by less than MAX_FOCAL_CHANGE (an oblique view; the 55-degree oblique render: 1-3 % per px).
CORNER_PROBE_PX = 1.0
MAX_FOCAL_CHANGE = 0.10


def _focal_from_homography(plane_to_image: np.ndarray, principal: np.ndarray) -> Optional[float]:
    """Zhang's constraints with square pixels and a known principal point; None when unobservable."""
    shift = np.array([[1, 0, -principal[0]], [0, 1, -principal[1]], [0, 0, 1.0]])
    h = shift @ plane_to_image
    h1, h2 = h[:, 0], h[:, 1]
    rows = [(h1[0] * h2[0] + h1[1] * h2[1], h1[2] * h2[2]),
            (h1[0] ** 2 + h1[1] ** 2 - h2[0] ** 2 - h2[1] ** 2, h1[2] ** 2 - h2[2] ** 2)]
    a = np.array([r[1] for r in rows])  # coefficient of f^2 ... written as a f^2 + b = 0 after scaling
    b = np.array([r[0] for r in rows])
    # b / f^2 + a = 0  ->  f^2 = -b / a, least squares in w = 1/f^2: b w = -a
    denom = float(b @ b)
    if denom <= 0:
        return None
    w = -float(b @ a) / denom
    if w <= 0:
        return None
    f = 1.0 / math.sqrt(w)
    # A near fronto-parallel view makes the constraints vanish: trust f only if they were well posed.
    scale = np.linalg.norm(h[:2, :2]) ** 2
    if np.max(np.abs(a)) * f * f < 1e-3 * scale:
        return None
    return f


def camera_matrix_for(plane_to_image: np.ndarray, image_size: tuple[int, int], known: Optional[np.ndarray] = None,
                      fovy_hint: float = 50.0) -> np.ndarray:
    """The camera matrix: the known one, else the focal length the plane homography reveals (principal
    point at the image centre), else, for a straight-down view that reveals none, the field-of-view hint."""
    if known is not None:
        return known
    return _camera_matrix(revealed_focal(plane_to_image, image_size), image_size, fovy_hint)


def revealed_focal(plane_to_image: np.ndarray, image_size: tuple[int, int]) -> Optional[float]:
    """The focal length (px) a plane's homography reveals with the principal point at the image centre, or None."""
    width, height = image_size
    f = _focal_from_homography(plane_to_image, np.array([width / 2 - 0.5, height / 2 - 0.5]))
    # Near straight down the constraints are close to vanishing without falling below the test above, and
    # the focal length they give can be any size (200 000 px, a camera 690 m up, for the 1.9 m overhead
    # render): no lens a table is filmed through sees less than MIN_FOVY_DEG, so such a value is no answer.
    if f is not None and f > (height / 2) / math.tan(math.radians(MIN_FOVY_DEG) / 2):
        f = None
    return f


def _camera_matrix(focal: Optional[float], image_size: tuple[int, int], fovy_hint: float) -> np.ndarray:
    """Square pixels, the principal point at the image centre; the field-of-view hint's focal length for None."""
    width, height = image_size
    f = focal if focal is not None else (height / 2) / math.tan(math.radians(fovy_hint) / 2)
    return np.array([[f, 0, width / 2 - 0.5], [0, f, height / 2 - 0.5], [0, 0, 1.0]])


def _camera_centre(plane_to_image: np.ndarray, k: np.ndarray) -> np.ndarray:
    """Camera centre in the plane's coordinates (x, y, height above the plane)."""
    m = np.linalg.inv(k) @ plane_to_image
    lam = 1.0 / np.linalg.norm(m[:, 0])
    if m[2, 2] < 0:
        lam = -lam  # the plane is in front of the camera
    r1, r2, t = lam * m[:, 0], lam * m[:, 1], lam * m[:, 2]
    r3 = np.cross(r1, r2)
    rotation = np.stack([r1, r2, r3], axis=1)
    u, _, vt = np.linalg.svd(rotation)
    rotation = u @ vt
    centre = -rotation.T @ t
    if centre[2] < 0:
        centre[2] = -centre[2]
    return centre


def fit_mapping(
    detected: dict[int, np.ndarray],
    layout: MarkerLayout,
    image_size: tuple[int, int],
    intrinsics: Optional[Intrinsics] = None,
    fovy_hint: float = 50.0,
    ball_height: float = BALL_CENTRE_HEIGHT,
) -> PlaneMapping:
    """The pixel <-> ball-plane mapping from tag centres (undistorted pixels), or MarkersError."""
    common = sorted(set(detected) & set(layout.positions))
    if len(common) < MIN_TAGS:
        raise MarkersError(
            f"{len(common)} of the markers file's tags are in view (ids seen {sorted(detected)}, "
            f"file has {layout.ids}); at least {MIN_TAGS} are needed"
        )
    if not _general_position(np.array([layout.positions[i][:2] for i in common])):
        raise MarkersError(f"the tags in view ({common}) lie on one line; a homography needs 4 spread over the table")
    pixels = np.array([detected[i] for i in common], float)
    world = np.array([layout.positions[i] for i in common], float)
    ids = np.array(common)
    dropped: dict[int, float] = {}
    z = world[:, 2]
    if np.ptp(z) < 1e-3:
        pixels, world, ids, dropped = _drop_worst_tags(pixels, world, ids)
        z_t = float(z.mean())
        h, _ = cv2.findHomography(pixels, world[:, :2], 0)
        if h is None:
            raise MarkersError("the tags seen do not determine a homography (degenerate layout)")
        fitted = cv2.perspectiveTransform(pixels.reshape(-1, 1, 2), h).reshape(-1, 2)
        residual = float(np.sqrt(np.mean(np.sum((fitted - world[:, :2]) ** 2, axis=1))))
        camera_height = math.nan
        if abs(z_t - ball_height) > 1e-4:
            k = camera_matrix_for(np.linalg.inv(h), image_size,
                                  intrinsics.camera_matrix if intrinsics is not None else None, fovy_hint)
            h, camera_height = _to_ball_plane(h, z_t, ball_height, k)
        image_to_table = h
    else:
        if len(common) < 6:
            raise MarkersError(f"tags at several heights need at least 6 in view for a projection fit, {len(common)} seen")
        projection = _dlt(world, pixels)
        plane = projection[:, [0, 1, 3]].copy()
        plane[:, 2] += projection[:, 2] * ball_height
        image_to_table = np.linalg.inv(plane)
        reproj = (projection @ np.c_[world, np.ones(len(world))].T).T
        reproj = reproj[:, :2] / reproj[:, 2:]
        metres_per_pixel = 1.0 / max(1e-9, np.median(np.linalg.norm(np.diff(pixels, axis=0), axis=1)
                                                   / np.linalg.norm(np.diff(world[:, :2], axis=0), axis=1)))
        residual = float(np.sqrt(np.mean(np.sum((reproj - pixels) ** 2, axis=1)))) * metres_per_pixel
        camera_height = math.nan
    image_to_table = image_to_table / image_to_table[2, 2]
    return PlaneMapping(image_to_table, np.linalg.inv(image_to_table), residual, len(pixels), camera_height, dropped)


def _to_ball_plane(image_to_plane: np.ndarray, plane_height: float, ball_height: float,
                   camera_matrix: np.ndarray) -> tuple[np.ndarray, float]:
    """The homography of a plane at plane_height moved along the viewing rays to the ball plane, and the camera's
    height above the ball plane."""
    centre = _camera_centre(np.linalg.inv(image_to_plane), camera_matrix)
    # Along each ray from the camera: the plane point p_t at z_t maps to the ball plane point
    # c + s (p_t - c), s = (h_c - dz) / h_c; as a homography acting on plane coordinates:
    dz = ball_height - plane_height
    s = (centre[2] - dz) / centre[2]
    shrink = np.array([[s, 0, (1 - s) * centre[0]], [0, s, (1 - s) * centre[1]], [0, 0, 1.0]])
    return shrink @ image_to_plane, float(centre[2]) - dz


def surface_homography(corners: np.ndarray, half_width: float, half_length: float) -> np.ndarray:
    """Undistorted pixels -> (x, y) on the surface, z = 0, from the field's corners in the order (-x,-y), (+x,-y),
    (+x,+y), (-x,+y). Four points fix it exactly (nothing to check them against)."""
    world = np.array([(-half_width, -half_length), (half_width, -half_length), (half_width, half_length),
                      (-half_width, half_length)], float)
    # Solved exactly in double precision: cv2.findHomography stops its refinement at about 1e-6 of a pixel's
    # worth, too coarse for the derivatives corner_refine takes of it.
    pixels = np.asarray(corners, float).reshape(4, 2)
    centre, scale = pixels.mean(axis=0), np.abs(pixels - pixels.mean(axis=0)).max() or 1.0
    normalised = (pixels - centre) / scale
    rows, values = [], []
    for (u, v), (x, y) in zip(normalised, world):
        rows += [[u, v, 1, 0, 0, 0, -x * u, -x * v], [0, 0, 0, u, v, 1, -y * u, -y * v]]
        values += [x, y]
    try:
        h = np.append(np.linalg.solve(np.array(rows), values), 1.0).reshape(3, 3)
    except np.linalg.LinAlgError:
        raise FieldCornersError("--field-corners: the corners do not determine a homography (three of them on a line)")
    if not np.all(np.isfinite(h)):
        raise FieldCornersError("--field-corners: the corners do not determine a homography (three of them on a line)")
    return h @ np.array([[1 / scale, 0, -centre[0] / scale], [0, 1 / scale, -centre[1] / scale], [0, 0, 1.0]])


def corner_camera_matrix(corners: np.ndarray, half_width: float, half_length: float, image_size: tuple[int, int],
                         intrinsics: Optional[Intrinsics] = None, fovy_hint: float = 50.0) -> np.ndarray:
    """The camera matrix for the field's corners (undistorted pixels): the intrinsics given, else the focal
    length the corners reveal (corner_focal), else the field-of-view hint's."""
    if intrinsics is not None:
        return intrinsics.camera_matrix
    return _camera_matrix(corner_focal(corners, half_width, half_length, image_size), image_size, fovy_hint)


def corner_focal(corners: np.ndarray, half_width: float, half_length: float,
                 image_size: tuple[int, int]) -> Optional[float]:
    """The focal length (px) the field's corners reveal where a pixel's error in any one of them changes it little,
    else None. Four corners fix a homography exactly, so their error goes straight into the focal length: seen
    from straight above, a corner off by 2 px made the 1.9 m overhead camera 7 m high."""
    corners = np.asarray(corners, float).reshape(4, 2)
    focal = revealed_focal(np.linalg.inv(surface_homography(corners, half_width, half_length)), image_size)
    for index in range(8):
        for step in (-CORNER_PROBE_PX, CORNER_PROBE_PX):
            if focal is None:
                return None
            moved = corners.copy().ravel()
            moved[index] += step
            other = revealed_focal(np.linalg.inv(surface_homography(moved, half_width, half_length)), image_size)
            if other is None or abs(other - focal) > MAX_FOCAL_CHANGE * focal:
                return None
    return focal


def fit_field_corners(corners: np.ndarray, half_width: float, half_length: float, ball_height: float,
                      image_size: tuple[int, int], intrinsics: Optional[Intrinsics] = None,
                      fovy_hint: float = 50.0) -> PlaneMapping:
    """The pixel <-> ball-plane mapping from the playing field's corners on the surface (z = 0), undistorted
    pixels in the order (-x,-y), (+x,-y), (+x,+y), (-x,+y): the surface's homography, moved up to the ball plane
    by the camera it implies (corner_camera_matrix), as for tags off that plane."""
    h = surface_homography(corners, half_width, half_length)
    k = corner_camera_matrix(corners, half_width, half_length, image_size, intrinsics, fovy_hint)
    h, camera_height = _to_ball_plane(h, 0.0, ball_height, k)
    image_to_table = h / h[2, 2]
    return PlaneMapping(image_to_table, np.linalg.inv(image_to_table), 0.0, 4, camera_height, {})


def _general_position(xy: np.ndarray, min_area: float = 0.005) -> bool:
    """Some 4 of the points have no 3 on a line (triangle areas above min_area, m^2)."""
    def area(a, b, c):
        return abs((b[0] - a[0]) * (c[1] - a[1]) - (b[1] - a[1]) * (c[0] - a[0])) / 2

    for quad in itertools.combinations(range(len(xy)), 4):
        if all(area(*xy[list(tri)]) > min_area for tri in itertools.combinations(quad, 3)):
            return True
    return False


def _drop_worst_tags(pixels: np.ndarray, world: np.ndarray, ids: np.ndarray):
    """Leave out tags that disagree with the rest (a misread id, a tag knocked off its place), one at a time."""
    dropped: dict[int, float] = {}
    # Keep one tag more than a homography needs, so what remains can still be checked against itself.
    while len(pixels) > MIN_TAGS + 1:
        h, _ = cv2.findHomography(pixels, world[:, :2], 0)
        if h is None:
            break
        fitted = cv2.perspectiveTransform(pixels.reshape(-1, 1, 2), h).reshape(-1, 2)
        if np.sqrt(np.mean(np.sum((fitted - world[:, :2]) ** 2, axis=1))) <= CONSISTENT_TAGS:
            break
        # Drop the tag whose absence leaves the most consistent rest: a homography is flexible enough to
        # bend toward one bad tag, so judging each tag by a fit that includes the bad one can blame the
        # wrong tag.
        best, best_rms, best_error = -1, math.inf, 0.0
        for i in range(len(pixels)):
            others = np.arange(len(pixels)) != i
            if not _general_position(world[others, :2]):
                continue
            h_i, _ = cv2.findHomography(pixels[others], world[others, :2], 0)
            if h_i is None:
                continue
            fitted_i = cv2.perspectiveTransform(pixels.reshape(-1, 1, 2), h_i).reshape(-1, 2)
            miss = np.linalg.norm(fitted_i - world[:, :2], axis=1)
            rms = float(np.sqrt(np.mean(miss[others] ** 2)))
            if rms < best_rms:
                best, best_rms, best_error = i, rms, float(miss[i])
        if best < 0:
            break
        keep = np.arange(len(pixels)) != best
        dropped[int(ids[best])] = best_error
        pixels, world, ids = pixels[keep], world[keep], ids[keep]
    return pixels, world, ids, dropped


def _dlt(world: np.ndarray, pixels: np.ndarray) -> np.ndarray:
    """3x4 projection matrix from >= 6 non-coplanar 3D-2D pairs (normalised DLT)."""
    rows = []
    for (x, y, z), (u, v) in zip(world, pixels):
        rows.append([x, y, z, 1, 0, 0, 0, 0, -u * x, -u * y, -u * z, -u])
        rows.append([0, 0, 0, 0, x, y, z, 1, -v * x, -v * y, -v * z, -v])
    _, _, vt = np.linalg.svd(np.asarray(rows))
    return vt[-1].reshape(3, 4)


def _detector_parameters():
    """The ArUco detector's settings, for the whole frame and (with rescaled perimeter limits) for the crops."""
    params = cv2.aruco.DetectorParameters()
    params.cornerRefinementMethod = cv2.aruco.CORNER_REFINE_SUBPIX
    # Far tags in an oblique view are ~3 px per cell and their borders blur: tolerate border bit
    # errors and correct as many data bits as the dictionary allows. A misread id cannot do harm:
    # tags that disagree with the rest are left out of the fit.
    params.maxErroneousBitsInBorderRate = 0.6
    params.errorCorrectionRate = 1.0
    return params


class TagLocator:
    """Detects the layout's ArUco tags and returns their centres in undistorted pixels."""

    def __init__(self, layout: MarkerLayout, lens: Lens):
        self.layout = layout
        self.lens = lens
        self.params = _detector_parameters()
        self.detector = cv2.aruco.ArucoDetector(layout.aruco_dictionary(), self.params)
        self._crop_detectors: dict[tuple[int, int], cv2.aruco.ArucoDetector] = {}  # (frame's side, crop's)
        self._last: dict[int, np.ndarray] = {}  # raw corners by id of the last detection in the whole frame
        self._whole_ids: list[int] = []  # the layout's tags it found, looked for in crops until TAG_WHOLE_EVERY
        self._crop_runs = 0

    def locate(self, bgr: np.ndarray) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
        """detect() on this BGR frame: only around where the layout's tags were last seen (the camera is mounted), in
        the whole frame when one of them is not found in its crop, and every TAG_WHOLE_EVERY calls while the whole
        frame has not shown them all (a tag hidden then may show now). ArUco's cost is the image's size: 40-60 ms on
        goal5's 1080p frames against 3-10 ms for its 4 tags' crops."""
        if self._whole_ids and (self._whole_ids == self.layout.ids or self._crop_runs < TAG_WHOLE_EVERY):
            found = self._detect_in_crops(bgr)
            if found is not None:
                self._crop_runs += 1
                return found
        found = self.detect(cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY))
        self._last, self._crop_runs = found[1], 0
        self._whole_ids = sorted(set(found[1]) & set(self.layout.ids))
        return found

    def _detect_in_crops(self, bgr: np.ndarray):
        """The layout's tags the whole frame showed, each looked for in a square crop around its last quad,
        TAG_CROP_MARGIN of the largest tag's sides (plus TAG_CROP_PAD px) beyond it, with the whole frame's size limits
        in pixels; None when one is not found there. (A tag of an id the layout lacks, a misread now and then, is left
        out of the fit anyway.)"""
        h, w = bgr.shape[:2]
        last = {tag_id: self._last[tag_id] for tag_id in self._whole_ids}
        side = max(float(np.max(np.ptp(quad, axis=0))) for quad in last.values())
        size = int(math.ceil((side * (1 + 2 * TAG_CROP_MARGIN) + 2 * TAG_CROP_PAD) / 16.0)) * 16
        if size > min(w, h):
            return None
        detector = self._crop_detector(max(w, h), size)
        quads = {}
        for tag_id, quad in last.items():
            # One size for every crop, moved inside the frame rather than cut at its edge: one detector serves them.
            cx, cy = quad.mean(axis=0)
            x0 = min(max(0, int(round(cx)) - size // 2), w - size)
            y0 = min(max(0, int(round(cy)) - size // 2), h - size)
            gray = cv2.cvtColor(bgr[y0:y0 + size, x0:x0 + size], cv2.COLOR_BGR2GRAY)
            corners, ids, _ = detector.detectMarkers(gray)
            if ids is None or tag_id not in ids.ravel():
                return None
            quads[tag_id] = [q.reshape(4, 2) + (x0, y0) for q, i in zip(corners, ids.ravel()) if i == tag_id][-1]
        self._last.update(quads)  # a mounted camera's tags drift by a fraction of a pixel: the crops follow
        return self._centres(quads), quads

    def _crop_detector(self, frame_side: int, crop_side: int):
        """A detector for square crops of this side whose marker perimeter limits (rates of the image's larger side)
        are the whole frame's in pixels."""
        key = (frame_side, crop_side)
        if key not in self._crop_detectors:
            params = _detector_parameters()
            params.minMarkerPerimeterRate = self.params.minMarkerPerimeterRate * frame_side / crop_side
            params.maxMarkerPerimeterRate = self.params.maxMarkerPerimeterRate * frame_side / crop_side
            self._crop_detectors[key] = cv2.aruco.ArucoDetector(self.layout.aruco_dictionary(), params)
        return self._crop_detectors[key]

    def detect(self, gray: np.ndarray) -> tuple[dict[int, np.ndarray], dict[int, np.ndarray]]:
        """(centres by id in undistorted pixels, raw corners by id) of every tag of the dictionary seen."""
        corners, ids, _ = self.detector.detectMarkers(gray)
        raw: dict[int, np.ndarray] = {}
        if ids is None:
            return {}, raw
        for quad, tag_id in zip(corners, ids.ravel()):
            raw[int(tag_id)] = quad.reshape(4, 2)
        return self._centres(raw), raw

    def _centres(self, raw: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
        return {tag_id: tag_centre(self.lens.undistort(quad)) for tag_id, quad in raw.items()}
