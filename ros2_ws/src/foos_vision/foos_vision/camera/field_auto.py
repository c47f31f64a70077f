"""`--field-corners auto`: the playing field's four corners found in the first frames, with no tags and no clicks.

How (find_field_corners):
1. The still table: the per-pixel median of up to FRAMES frames spread over the first SPAN_S seconds, so the ball,
   hands and swinging figures mostly drop out.
2. The felt: the commonest colour of the image's middle (a hue for coloured felt, a lightness for black or grey
   felt), every pixel of that colour, closed over the rods and the lines, the largest piece in the middle with its
   holes (figures, the centre circle) filled. Narrower closings (CLOSE_SHARES) are tried where the field found
   with a wider one does not hold up (a thin wall bridged to a floor of the felt's shade).
3. Its four sides: of the quadrilaterals along sides of the piece's simplified convex hull that hold it all, the
   smallest (a felt with corner ramps, an octagon, gives its four long sides). Across each side's middle
   (CORNER_SKIP of it left out at each end: corner ramps, posts) the felt's edge is found to a fraction of a pixel
   on the full-resolution felt mask, an end's goal mouth left out where the end has enough beside it, and a line
   is fitted to those points, robustly (a figure or a hand at the edge is dropped). With --intrinsics the points
   are undistorted first; without, a barrel lens is straightened by field_lines.DivisionLens, fitted to the sides.
4. The table's frame: the corners' camera (the intrinsics, else the focal length the quadrilateral reveals, else
   a 50 degree hint) measures the field's aspect, and the longer pair of sides is the length (y). The home end (-y)
   is the left end of a field lying across the image, the bottom end of one lying up and down it (a camera behind
   the home goal); the other end is the mirror image of this one, so no picture can tell them apart.
5. The walls: seen from outside a wall's plane (behind a goal), the felt ends at the wall's top edge, not at the
   surface, which the wall hides: the corners are fitted (corner_refine.fit_corners_to_lines) with that side at the
   wall's height, the others on the surface. A felt more than BORDER_ASPECT off the table's shape may have a border
   of the surface round it: the walls are looked for beyond it (field_walls.walls_round_felt).
6. How sure: per side, the share of its middle along which the edge was found on its line (support), and the
   points' RMS distance from it; the field's aspect against the table's. confidence = the least support times
   (1 - aspect error / MAX_ASPECT_ERROR), halved for grey or black felt (GREY_FELT_TRUST); below MIN_SUPPORT, or an
   aspect further off, is no field (FieldNotFound).
The tracker then fits the corners to the table's edges as it does clicked ones (corner_refine).
"""
from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field
from typing import Iterable, Optional

import cv2
import numpy as np

from foos_core.camera_model import Intrinsics

from .corner_refine import camera_of_corners, fit_corners_to_lines, wall_faces_seen
from .field_corners import CORNER_ORDER, FieldCornersError
from .field_lines import (
    CORNER_SKIP,
    MIN_SUPPORT,
    SAMPLES_PER_SIDE,
    STEP_PX,
    DivisionLens,
    NoIntersection,
    intersect,
    robust_line,
)
from .field_walls import walls_round_felt
from .geometry import Lens, corner_camera_matrix

AUTO = "auto"
FRAMES = 9  # the still table is the median of this many frames ...
SPAN_S = 2.0  # ... spread over the first this many seconds of the video
WORK_WIDTH = 960  # px: the felt's piece is found at this width; its edges at full resolution
CENTRE_BOX = 0.3  # the felt's colour is read from the middle box this share of the image wide and high
MIN_CENTRE_FELT = 0.25  # of that box the felt's colour covers, at least
MIN_FELT_CHROMA = 12.0  # Lab chroma: felt less colourful than this is grey or black, told by its lightness
HUE_TOL_DEG = 20.0  # coloured felt: its hue, in light and in shade ...
CHROMA_RANGE = (0.4, 2.5)  # ... with a chroma this share of its middle's
# Grey or black felt: chroma at most this above its middle's (a wall's inner face in shade keeps some of the wall's
# colour: 8-9 on the renders' dark-brown walls, against black felt's 1-3) ...
GREY_CHROMA_TOL = 5.0
GREY_LIGHT_TOL = 25.0  # ... and lightness this close at most, ...
GREY_LIGHT_MIN = 12.0  # ... at least ...
GREY_SPREADS = 4.0  # ... and else this many times the lightness's spread in the image's middle
# Grey or black felt is told from the walls by its lightness and a low chroma, and walls in shade can pass for it
# (renders of random cameras: grey 5 of 8 within 4 px, black 6 of 7, coloured 8 of 9; the achromatic misses had
# confidences up to 0.88): its confidence is halved.
GREY_FELT_TRUST = 0.5
CLOSE_SHARES = (0.02, 0.012, 0.007)  # of the work width: the closings tried to bridge rods and lines, widest first
MIN_FIELD_SHARE = 0.05  # of the image: a felt piece smaller than this is not a table's field
MAX_BORDER_SHARE = 0.05  # of the image's edge the felt's piece may touch (the field's walls are in view)
# Of the sides' mean length: how far across each side its edge is looked for (a bent side's bow, and the goal line
# in front of a pocket of felt the outline took for the end, fit in it).
SEARCH_SHARE = 0.08
MIN_SEARCH_PX = 6.0
MOUTH_MARGIN = 0.03  # m beyond each goal post left out of an end's edge
MAX_ASPECT_ERROR = 0.25  # the field's length over its width, measured against the table's: further off is no field
FOVY_HINT = 50.0
BORDER_ASPECT = 0.05  # a felt further than this from the table's aspect is looked at for a border to the walls
HULL_SIMPLIFY = (0.005, 0.01, 0.02, 0.04)  # of the hull's perimeter: the tolerances tried, finest first, ...
MAX_HULL_SIDES = 12  # ... until the hull has at most this many sides
WALL_FIT_ROUNDS = 20


class FieldNotFound(FieldCornersError):
    """--field-corners auto found no playing field in the first frames."""


@dataclass
class FoundCorners:
    """The playing field's corners found in the image (distorted pixels, CORNER_ORDER) and how sure that is."""

    pixels: np.ndarray  # (4, 2)
    support: np.ndarray  # (4,) per side from corner i to i + 1: share of its middle on its line
    rms_px: np.ndarray  # (4,) per side: its edge points' RMS distance from the fitted line (undistorted px)
    aspect: float  # the field's length over its width as the corners' camera measures it
    expected_aspect: float  # the table's
    walls_from_behind: list[int]  # sides whose felt edge is their wall's top (the camera is behind that wall)
    frames: int  # frames the still table was made of
    seconds: float  # time the search took
    bend: float = 0.0  # the lens's barrel bend the sides were straightened by (DivisionLens.strength; 0: none)
    bordered: list[int] = field(default_factory=list)  # sides taken at the wall found beyond the felt's edge
    coloured_felt: bool = True  # the felt told by its hue; else by its lightness alone (grey or black felt)

    @property
    def aspect_error(self) -> float:
        return abs(self.aspect / self.expected_aspect - 1.0)

    @property
    def confidence(self) -> float:
        trust = 1.0 if self.coloured_felt else GREY_FELT_TRUST
        return float(max(0.0, min(1.0, trust * float(np.min(self.support))
                                  * (1.0 - self.aspect_error / MAX_ASPECT_ERROR))))

    def summary(self) -> str:
        corners = ",".join(f"{v:.1f}" for v in self.pixels.ravel())
        sides = ", ".join(f"{s:.0%}/{r:.1f}" for s, r in zip(self.support, self.rms_px))
        behind = f"; sides {[i + 1 for i in self.walls_from_behind]} at their wall's top" if self.walls_from_behind else ""
        behind += f"; sides straightened (lens bend {self.bend:.3f})" if self.bend else ""
        behind += (f"; sides {[i + 1 for i in self.bordered]} at the walls beyond a border round the felt"
                   if self.bordered else "")
        behind += "" if self.coloured_felt else "; grey or black felt (told by its lightness: walls in shade pass for it)"
        return (f"field corners found: {corners} (px, {CORNER_ORDER}); confidence {self.confidence:.2f}: sides on "
                f"their line {sides} px RMS, aspect {self.aspect:.2f} (table {self.expected_aspect:.2f}){behind}; "
                f"{self.frames} frames, {self.seconds:.2f} s")


def is_auto(value) -> bool:
    return isinstance(value, str) and value.strip().lower() == AUTO


def still_frames(frames: Iterable[tuple[int, float, np.ndarray]], fps: float) -> list[np.ndarray]:
    """Up to FRAMES frames spread over the first SPAN_S seconds of (index, t, bgr) frames."""
    every = max(1, int(round(SPAN_S * fps / FRAMES)))
    chosen = []
    for index, _, frame in frames:
        if index % every == 0:
            chosen.append(frame)
        if len(chosen) >= FRAMES or index >= SPAN_S * fps:
            break
    return chosen


def find_field_corners(frames: list[np.ndarray], half_width: float, half_length: float, goal_half_width: float,
                       wall_height: float, intrinsics: Optional[Intrinsics] = None) -> FoundCorners:
    """The field's corners in frames of a camera that does not move (see the module's docstring); FieldNotFound
    (one line) where there is no field."""
    started = cv2.getTickCount()
    if not frames:
        raise FieldNotFound("--field-corners auto: the video has no frames to find the field in")
    still = frames[0] if len(frames) == 1 else np.median(np.stack(frames), axis=0).astype(np.uint8)
    felt, coloured = _felt_colour(still)
    # A wide closing bridges rods and lines, and can bridge a thin wall to a floor of the felt's shade beyond it:
    # narrower ones are tried where the field found with it does not hold up.
    first_error = None
    for share in CLOSE_SHARES:
        try:
            result = _find_in(still, felt, share, half_width, half_length, goal_half_width, wall_height, intrinsics)
            break
        except FieldNotFound as error:
            first_error = first_error or error
    else:
        raise first_error
    result.coloured_felt = coloured
    result.frames = len(frames)
    result.seconds = (cv2.getTickCount() - started) / cv2.getTickFrequency()
    return result


def _find_in(still: np.ndarray, felt: np.ndarray, close_share: float, half_width: float, half_length: float,
             goal_half_width: float, wall_height: float, intrinsics: Optional[Intrinsics]) -> FoundCorners:
    """find_field_corners with one closing of the felt."""
    lens = Lens(intrinsics)
    region, felt = _felt_piece(felt, close_share)
    height, width = felt.shape
    quad = _table_order(_rough_quadrilateral(region), lens, intrinsics, (width, height))
    soft = cv2.GaussianBlur(felt.astype(np.float32), (0, 0), 1.0)
    search = max(MIN_SEARCH_PX, SEARCH_SHARE * float(np.mean(np.linalg.norm(np.roll(quad, -1, axis=0) - quad, axis=1))))
    found, along = zip(*[_edge_points(soft, quad[i], quad[(i + 1) % 4], search) for i in range(4)])
    if intrinsics is None:
        lens = DivisionLens.straightening(list(found), (width, height))
    lines, points, support, rms = [], [], [], []
    grid = np.linspace(CORNER_SKIP, 1.0 - CORNER_SKIP, SAMPLES_PER_SIDE)
    for i in range(4):
        undistorted = lens.undistort(found[i]) if len(found[i]) else found[i]
        line, inliers = robust_line(undistorted)
        samples = SAMPLES_PER_SIDE
        if i in (0, 2) and len(undistorted):
            # An end: where the felt runs on into the goal's pocket, its edge there is not the goal line. The end's
            # edge beside the mouth decides where it has enough (a corner ramp can leave little but the mouth).
            mouth = goal_half_width + MOUTH_MARGIN
            beside = np.abs(2.0 * along[i] - 1.0) * half_width >= mouth
            places = int(np.sum(np.abs(2.0 * grid - 1.0) * half_width >= mouth))
            line_beside, inliers_beside = robust_line(undistorted[beside])
            if line_beside is not None and inliers_beside.sum() >= MIN_SUPPORT * places:
                line, samples = line_beside, places
                inliers = np.zeros(len(undistorted), bool)
                inliers[np.flatnonzero(beside)[inliers_beside]] = True
        if line is None or inliers.sum() < MIN_SUPPORT * samples:
            share = 0.0 if line is None else inliers.sum() / samples
            raise FieldNotFound(f"--field-corners auto: the felt's side {i + 1} ({_side_name(i)}) is not a straight "
                                f"edge ({share:.0%} of it on one line, {MIN_SUPPORT:.0%} needed): no field found; "
                                f"give --field-corners U1,V1,...")
        lines.append(line)
        points.append(undistorted[inliers])
        support.append(min(1.0, inliers.sum() / samples))
        rms.append(float(np.sqrt(np.mean((undistorted[inliers] @ line[:2] - line[2]) ** 2))))
    corners = np.array([_meet(lines[i - 1], lines[i]) for i in range(4)])
    size = (width, height)
    k = corner_camera_matrix(corners, half_width, half_length, size, intrinsics, FOVY_HINT)
    camera = camera_of_corners(corners, k, size, half_width, half_length)
    seen = wall_faces_seen(camera, half_width, half_length)
    behind = [i for i in range(4) if not seen[i]]
    if behind:
        table = np.array([(-half_width, -half_length), (half_width, -half_length), (half_width, half_length),
                          (-half_width, half_length)])
        z = [0.0 if seen[i] else wall_height for i in range(4)]
        edges = [(np.append(table[i], z[i]), np.append(table[(i + 1) % 4], z[i]), points[i]) for i in range(4)]
        # The wall's height in the image depends on the focal length, which only the corners themselves reveal:
        # fitted with the focal length of the last corners held, until they no longer move.
        for _ in range(WALL_FIT_ROUNDS):
            moved, _, residuals = fit_corners_to_lines(corners, edges, k, size, half_width, half_length, wall_height,
                                                       0.0, focal_sigma=1e-4)
            step = float(np.max(np.linalg.norm(moved - corners, axis=1)))
            corners = moved
            k = corner_camera_matrix(corners, half_width, half_length, size, intrinsics, FOVY_HINT)
            if step < 0.01:
                break
        rms = [float(np.sqrt(np.mean(r ** 2))) for r in residuals]
    aspect = _aspect(corners, k)
    bordered: list[int] = []
    if not behind and abs(aspect / (half_length / half_width) - 1.0) > BORDER_ASPECT:
        walls = walls_round_felt(cv2.cvtColor(still, cv2.COLOR_BGR2GRAY), corners, aspect, lens, half_width,
                                  half_length)
        if walls is not None:
            for i, (line, share, spread) in walls.items():
                lines[i], support[i], rms[i] = line, share, spread
            corners = np.array([_meet(lines[i - 1], lines[i]) for i in range(4)])
            k = corner_camera_matrix(corners, half_width, half_length, size, intrinsics, FOVY_HINT)
            aspect, bordered = _aspect(corners, k), sorted(walls)
    result = FoundCorners(lens.distort(corners), np.array(support), np.array(rms), aspect, half_length / half_width,
                          behind, 0, 0.0, getattr(lens, "strength", 0.0), bordered)
    if result.aspect_error > MAX_ASPECT_ERROR:
        raise FieldNotFound(f"--field-corners auto: the quadrilateral found is {aspect:.2f} times as long as wide, the "
                            f"table {result.expected_aspect:.2f}: no field found; give --field-corners U1,V1,... or "
                            f"--field-size")
    for index, (u, v) in enumerate(result.pixels, start=1):
        if not (-0.5 <= u <= width - 0.5 and -0.5 <= v <= height - 0.5):
            raise FieldNotFound(f"--field-corners auto: corner {index} falls outside the image at ({u:.0f}, {v:.0f}); "
                                f"the whole field must be in view")
    return result


def _side_name(i: int) -> str:
    return ("home end", "+x side", "away end", "-x side")[i]


def _felt_colour(bgr: np.ndarray) -> tuple[np.ndarray, bool]:
    """Full-resolution uint8 mask of the felt's colour (1), the commonest of the image's middle; whether the felt is
    coloured (told by its hue), not grey or black (told by its lightness alone)."""
    height, width = bgr.shape[:2]
    lab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab).astype(np.float32)
    light, a, b = lab[..., 0] * (100.0 / 255.0), lab[..., 1] - 128.0, lab[..., 2] - 128.0
    chroma = np.hypot(a, b)
    hue = np.degrees(np.arctan2(b, a))
    h0, h1 = int(height * (0.5 - CENTRE_BOX / 2)), int(height * (0.5 + CENTRE_BOX / 2))
    w0, w1 = int(width * (0.5 - CENTRE_BOX / 2)), int(width * (0.5 + CENTRE_BOX / 2))
    c_mid, h_mid, l_mid = (x[h0:h1, w0:w1].ravel() for x in (chroma, hue, light))
    # The felt's colour: the commonest hue among the middle's coloured pixels, else (grey or black felt) the
    # commonest lightness among its grey ones.
    coloured = c_mid >= MIN_FELT_CHROMA
    felt = None
    if coloured.mean() >= MIN_CENTRE_FELT:
        counts, edges = np.histogram(h_mid[coloured], bins=72, range=(-180, 180))
        counts = counts + np.roll(counts, 1) + np.roll(counts, -1)
        hue0 = float(edges[np.argmax(counts)] + 2.5)
        near = coloured & (np.abs(_angle(h_mid - hue0)) <= HUE_TOL_DEG)
        if near.mean() >= MIN_CENTRE_FELT:
            hue0 = float(np.degrees(np.angle(np.mean(np.exp(1j * np.radians(h_mid[near]))))))
            c0 = float(np.median(c_mid[near]))
            felt = ((np.abs(_angle(hue - hue0)) <= HUE_TOL_DEG) & (chroma >= CHROMA_RANGE[0] * c0)
                    & (chroma <= CHROMA_RANGE[1] * c0))
    if felt is None:
        grey = c_mid < MIN_FELT_CHROMA
        if grey.mean() < MIN_CENTRE_FELT:
            raise FieldNotFound("--field-corners auto: no one felt colour fills the image's middle: no field found; "
                                "give --field-corners U1,V1,...")
        counts, edges = np.histogram(l_mid[grey], bins=50, range=(0, 100))
        l0 = float(edges[np.argmax(counts)] + 1.0)
        near = grey & (np.abs(l_mid - l0) <= GREY_LIGHT_TOL)
        l0 = float(np.median(l_mid[near]))
        c0 = float(np.median(c_mid[near]))
        # Grey felt is told from a grey room by its lightness alone: as narrow as the felt's own spread allows.
        spread = 1.4826 * float(np.median(np.abs(l_mid[near] - l0)))
        light_tol = float(np.clip(GREY_SPREADS * spread, GREY_LIGHT_MIN, GREY_LIGHT_TOL))
        felt = (chroma <= c0 + GREY_CHROMA_TOL) & (np.abs(light - l0) <= light_tol)
        return felt.astype(np.uint8), False
    return felt.astype(np.uint8), True


def _felt_piece(felt: np.ndarray, close_share: float) -> tuple[np.ndarray, np.ndarray]:
    """Full-resolution uint8 masks: the felt's piece in the image's middle, closed over rods and lines (a closing
    close_share of the work width) with its holes filled (its outline the field's, to a few pixels); and the felt's
    own pixels along that outline with the inside filled (its edges to a fraction of a pixel)."""
    height, width = felt.shape
    scale = min(1.0, WORK_WIDTH / width)
    small = cv2.resize(felt, (round(width * scale), round(height * scale)), interpolation=cv2.INTER_AREA)
    small = cv2.morphologyEx(small, cv2.MORPH_OPEN, np.ones((3, 3), np.uint8))
    k = max(3, int(close_share * small.shape[1]) | 1)
    filled = _piece(cv2.morphologyEx(small, cv2.MORPH_CLOSE, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (k, k))))
    region = cv2.resize(filled, (width, height), interpolation=cv2.INTER_NEAREST)
    # Full resolution: the felt's pixels within the piece (grown a little, so its true edge is inside), the inside
    # of the piece shrunk filled (figures, lines), so the only edge left is the outline's.
    grow = max(3, int(round(k / scale)) | 1)
    outer = cv2.dilate(region, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (grow, grow)))
    inner = cv2.erode(region, cv2.getStructuringElement(cv2.MORPH_ELLIPSE, (2 * grow + 1, 2 * grow + 1)))
    return region, ((felt & outer) | inner).astype(np.uint8)


def _piece(closed: np.ndarray) -> np.ndarray:
    """The closed felt's piece in the image's middle, holes filled; FieldNotFound where it is too small or runs off
    the image."""
    count, labels, stats, _ = cv2.connectedComponentsWithStats(closed, connectivity=8)
    sh, sw = closed.shape
    middle = labels[int(sh * 0.4):int(sh * 0.6), int(sw * 0.4):int(sw * 0.6)]
    ids = np.unique(middle[middle > 0])
    if len(ids) == 0:
        raise FieldNotFound("--field-corners auto: no felt in the image's middle: no field found; give --field-corners "
                            "U1,V1,...")
    piece = ids[np.argmax(stats[ids, cv2.CC_STAT_AREA])]
    if stats[piece, cv2.CC_STAT_AREA] < MIN_FIELD_SHARE * sh * sw:
        raise FieldNotFound(f"--field-corners auto: the felt found covers {stats[piece, cv2.CC_STAT_AREA] / (sh * sw):.0%} "
                            f"of the image: no field found; give --field-corners U1,V1,...")
    own = (labels == piece).astype(np.uint8)
    border = np.concatenate([own[0], own[-1], own[:, 0], own[:, -1]])
    if border.mean() > MAX_BORDER_SHARE:
        raise FieldNotFound(f"--field-corners auto: the felt runs off the image ({border.mean():.0%} of the image's edge): "
                            f"the whole field and its walls must be in view; no field found")
    contours, _ = cv2.findContours(own, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_NONE)
    filled = np.zeros_like(closed)
    cv2.drawContours(filled, contours, -1, 1, thickness=-1)
    return filled


def _angle(degrees: np.ndarray) -> np.ndarray:
    return (degrees + 180.0) % 360.0 - 180.0


def _rough_quadrilateral(region: np.ndarray) -> np.ndarray:
    """Four corners (full-resolution px) of the felt piece, counter-clockwise on the screen: of the quadrilaterals
    whose sides lie along sides of its simplified convex hull and hold the whole hull, the smallest. A felt whose
    corners are cut off (corner ramps: an octagon) then gives the quadrilateral of its four long sides."""
    contours, _ = cv2.findContours(region, cv2.RETR_EXTERNAL, cv2.CHAIN_APPROX_SIMPLE)
    hull = cv2.convexHull(max(contours, key=cv2.contourArea))
    perimeter = cv2.arcLength(hull, True)
    polygon = None
    for share in HULL_SIMPLIFY:
        polygon = cv2.approxPolyDP(hull, share * perimeter, True).reshape(-1, 2).astype(float)
        if len(polygon) <= MAX_HULL_SIDES:
            break
    if polygon is None or len(polygon) < 4:
        raise FieldNotFound("--field-corners auto: the felt's outline is not a quadrilateral: no field found; give "
                            "--field-corners U1,V1,...")
    if _signed_area(polygon) > 0:
        polygon = polygon[::-1].copy()  # counter-clockwise on the screen (v down): negative area
    n = len(polygon)
    lines = [np.cross(np.append(polygon[i], 1.0), np.append(polygon[(i + 1) % n], 1.0)) for i in range(n)]
    tolerance = 0.01 * perimeter
    best, best_area = None, math.inf
    for chosen in itertools.combinations(range(n), 4):
        corners = []
        for j in range(4):
            p = np.cross(lines[chosen[j - 1]], lines[chosen[j]])
            if abs(p[2]) < 1e-9:
                break
            corners.append(p[:2] / p[2])
        if len(corners) < 4:
            continue
        quad = np.array(corners)
        area = -_signed_area(quad)
        if area <= 0 or area >= best_area or not _convex(quad):
            continue
        if all(cv2.pointPolygonTest(quad.astype(np.float32).reshape(-1, 1, 2), (float(u), float(v)), True)
                          >= -tolerance for u, v in polygon):
            best, best_area = quad, area
    if best is None:
        raise FieldNotFound("--field-corners auto: the felt's outline is not a quadrilateral: no field found; give "
                            "--field-corners U1,V1,...")
    return best


def _signed_area(polygon: np.ndarray) -> float:
    """Positive when the points go clockwise on the screen (v down)."""
    u, v = polygon[:, 0], polygon[:, 1]
    return float(np.sum(u * np.roll(v, -1) - np.roll(u, -1) * v) / 2)


def _convex(quad: np.ndarray) -> bool:
    sides = np.roll(quad, -1, axis=0) - quad
    into = np.roll(sides, 1, axis=0)
    turns = into[:, 0] * sides[:, 1] - into[:, 1] * sides[:, 0]
    return bool(np.all(turns < 0))


def _table_order(quad: np.ndarray, lens: Lens, intrinsics: Optional[Intrinsics],
                 size: tuple[int, int]) -> np.ndarray:
    """The quadrilateral's corners (counter-clockwise on the screen) rolled into CORNER_ORDER: its longer pair of
    sides (as a camera sees them) along y, the home end the left one of a field lying across the image, else the
    bottom one."""
    undistorted = lens.undistort(quad)
    if intrinsics is not None:
        k = intrinsics.camera_matrix
    else:
        # Only the sides' right angle is known (not yet which is the length): the focal length it reveals, else the hint.
        h = cv2.getPerspectiveTransform(np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32),
                                        undistorted.astype(np.float32))
        h = np.array([[1, 0, -(size[0] / 2 - 0.5)], [0, 1, -(size[1] / 2 - 0.5)], [0, 0, 1.0]]) @ h
        product = h[0, 0] * h[0, 1] + h[1, 0] * h[1, 1]
        f2 = -product / (h[2, 0] * h[2, 1]) if abs(h[2, 0] * h[2, 1]) > 1e-12 else -1.0
        hint = (size[1] / 2) / math.tan(math.radians(FOVY_HINT) / 2)
        f = math.sqrt(f2) if 0.2 * hint < math.sqrt(max(f2, 0.0)) < 10 * hint else hint
        k = np.array([[f, 0, size[0] / 2 - 0.5], [0, f, size[1] / 2 - 0.5], [0, 0, 1.0]])
    if _aspect(undistorted, k) < 1.0:
        quad = np.roll(quad, -1, axis=0)  # corner 0 -> 1 is then a short side: an end
    return home_end_first(quad)


def home_end_first(corners: np.ndarray) -> np.ndarray:
    """Corners in CORNER_ORDER up to the ends' exchange, rolled so that the home end (corners 1 and 2) is the left
    end of a field lying across the image, the bottom end of one lying up and down it."""
    corners = np.asarray(corners, float)
    home, away = (corners[0] + corners[1]) / 2, (corners[2] + corners[3]) / 2
    along = away - home
    home_first = home[0] < away[0] if abs(along[0]) >= abs(along[1]) else home[1] > away[1]
    return corners if home_first else np.roll(corners, -2, axis=0)


def _edge_points(soft: np.ndarray, a: np.ndarray, b: np.ndarray, search: float) -> tuple[np.ndarray, np.ndarray]:
    """Where the felt ends across the middle of side a -> b (full-resolution px): per sample, the half-level
    crossing from felt to not felt nearest the side's line (none where there is none within the search); and each
    point's place along the side (0 at a, 1 at b)."""
    length = float(np.linalg.norm(b - a))
    direction = (b - a) / length
    outward = np.array([-direction[1], direction[0]])  # counter-clockwise on the screen (v down): felt on the right
    s = np.linspace(CORNER_SKIP, 1.0 - CORNER_SKIP, SAMPLES_PER_SIDE)
    offsets = np.arange(-search, search + 1e-9, STEP_PX)
    centres = a + s[:, None] * (b - a)
    across = centres[:, None, :] + offsets[None, :, None] * outward
    profiles = cv2.remap(soft, across[..., 0].astype(np.float32), across[..., 1].astype(np.float32), cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=0.0)
    level = profiles - 0.5
    crossing = (level[:, :-1] >= 0) & (level[:, 1:] < 0)  # felt, then not felt, going outward
    distance = np.where(crossing, np.abs(offsets[:-1] + STEP_PX / 2)[None, :], np.inf)
    k = np.argmin(distance, axis=1)
    rows = np.arange(len(s))
    keep = np.isfinite(distance[rows, k])
    before, after = level[rows, k], level[rows, k + 1]
    fraction = before / np.where(before - after > 0, before - after, 1.0)
    where = offsets[k] + fraction * STEP_PX
    return (centres + where[:, None] * outward)[keep], s[keep]


def _meet(l1: np.ndarray, l2: np.ndarray) -> np.ndarray:
    try:
        return intersect(l1, l2)
    except NoIntersection:
        raise FieldNotFound("--field-corners auto: two neighbouring sides of the felt are parallel: no field found") \
            from None


def _aspect(corners: np.ndarray, camera_matrix: np.ndarray) -> float:
    """The rectangle's side (corner 1 -> 2) over its side (0 -> 1), as this camera sees the quadrilateral."""
    square = np.array([[0, 0], [1, 0], [1, 1], [0, 1]], np.float32)
    h = cv2.getPerspectiveTransform(square, np.asarray(corners, np.float32))
    m = np.linalg.inv(camera_matrix) @ h
    return float(np.linalg.norm(m[:, 1]) / np.linalg.norm(m[:, 0]))
