"""The tracker: frames in, ball positions in the table frame out (ROS-free; the node and CLI wrap it)."""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field
from typing import Optional

import cv2
import numpy as np

from .camera import Intrinsics
from .detector import BALL_COLOR_NAMES, BallDetector, Candidate, ColourModel, colour_model, learn_colour
from .errors import MarkersError
from .figure_mask import FigureGeometry, FigureMasker, projection_from_mapping
from .geometry import MAX_TAG_RESIDUAL, Lens, PlaneMapping, TagLocator, fit_mapping
from .markers import BALL_CENTRE_HEIGHT, MarkerLayout
from .rod_lines import (
    STEEL_AB_TOL,
    RodGeometry,
    camera_centre,
    fit_rod_shifts,
    on_rod_line,
    rod_axis_mask,
    rod_bands,
    rod_geometry,
    rod_mask,
)
from .velocity import ConstantVelocityKalman, KalmanState

BALL_RADIUS = 0.0175
# Longest a track may live on partly hidden blobs alone: WEAK_TRACK_LIMIT seconds or WEAK_TRACK_FRAMES frames,
# whichever is longer. What tells a ball under a rod from a figure of its colour is the number of frames in
# which the part moves as the ball would; at 25 fps 0.15 s is under 4 frames, less than a ball takes to come
# out from under a rod.
WEAK_TRACK_LIMIT, WEAK_TRACK_FRAMES = 0.15, 8
# Where figures of the ball's colour are guarded against (BallTracker.figures_guarded: the figure mask, or a
# coloured ball, whose figures' heads over their rods are dropped), the rules against them are relaxed: a track
# may live on partial blobs this long (s), and a run of partial blobs starts a track (PARTIAL_RUN), at rest too
# (a ball resting half under a rod).
MASKED_WEAK_TRACK_LIMIT = 2.0
MAX_GATE = 0.12  # m: the farthest a track may jump between two frames
RADIUS_GRID = 16  # px, spacing of the expected-radius lookup
BAND_SEEDS_NEAR = False
COAST_SPEED = 1.5  # m/s: the speed change a hit can give a hidden ball, for the gate while a track coasts
MIN_PARTIAL_FILL = 0.4  # share of the inner disc a partly hidden ball must fill
MAX_SPILL = 0.15  # blob pixels 1.25-1.8 radii out / disc area: more, and the blob is merged with something of its colour
MIN_SCORE = 0.2  # candidate score (visible share x roundness) below which a blob is not a ball
# Near a sure prediction a half ball under a rod scores lower (a half disc is 0.5 round, shading takes more of
# its pixels): there it may score this little, if its centre lies within PARTIAL_NEAR radii of the prediction
# and it shows at least PARTIAL_MIN_RATIO of the disc (a thinner sliver's centre is a guess).
PARTIAL_MIN_SCORE, PARTIAL_NEAR, PARTIAL_MIN_RATIO = 0.1, 0.6, 0.28
ACQUIRE_WINDOW = 0.1  # s: two sightings this close in time confirm a new track (25 fps, or a live feed dropping frames)
ACQUIRE_SOLID_RATIO = 0.6  # a white ball's shaded side leaves its colour box: 0.7 of the disc is typical
CONFIDENT_RUN = 3
# Where figures are guarded against, a new track from partial blobs alone: this many frames running of a partly
# hidden ball (a ball coming out from under a rod, or resting beside one, while no track runs) whose centres lie
# on one straight, steady path (within PARTIAL_RUN_FIT m RMS), moving or at rest. Never otherwise (a white ball
# without the mask): a figure of the ball's colour sliding with its rod (or at rest) makes such a run. 0: off.
PARTIAL_RUN, PARTIAL_RUN_FIT = 4, 0.003
HALF_RES_RATIO, HALF_RES_ROUNDNESS = 0.3, 0.4  # field search at half resolution: blobs worth a full-resolution look
ELSEWHERE_EVERY = 3  # frames between searches of the whole field for a whole ball while the track is weak
HEALTHY_FILL, HEALTHY_ROUNDNESS = 0.75, 0.8  # or a single frame this filled and round  # ball-like frames in a row that make a track on partial blobs healthy again
AUTO_MIN_SHARE = 0.3  # auto colour: share of the frames looked at in which the winner saw one moving ball
# Auto colour votes over at most this many recent frames: a live feed with no ball in view for minutes must
# not make every frame compare its blobs with all frames so far (the bench's videos settle within 120).
AUTO_WINDOW = 300
# A blob in a rod's band seen again this close in ball-plane y (m) and at least this far along x (m) is a figure
# sliding with its rod, for the auto colour vote (rod_lines).
ROD_LINE_Y_TOL, ROD_LINE_MIN_DX = 0.004, 0.010
# A blob with a rod's axis beside its centre mostly in the ball's colour covers the rod: a figure of that colour
# (the rod runs through its body), never the ball, which is below every rod (_covers_rod). The axis is looked at
# within ROD_COVER_RADIUS expected radii of the centre and ROD_COVER_ALONG radii along the rod of its nearest
# point; covered when ROD_COVER_SHARE of it is within ROD_COVER_AB times the colour model's a/b tolerance.
# Only for coloured balls: a white ball is as grey as steel's highlights.
ROD_COVER_RADIUS, ROD_COVER_ALONG, ROD_COVER_SHARE, ROD_COVER_AB = 1.3, 0.5, 0.5, 1.6
# Radii from a blob within which pixels of (nearly) its colour joining it to a covered rod's axis make it part of a
# figure: a kicked leg reaches its foot's end 78 mm (4.5 radii) from the axis.
FIGURE_REACH = 5.0
# Radii along the rod between such a blob's centre and the middle of the covered stretch it is joined to, within
# which it is a figure's leg or foot (straight across the rod from its body); a ball touching a figure along the
# rod lies at least its radius and the figure's half width (1.7 radii for a 24 mm body) from the body's middle.
FIGURE_ALONG = 0.8
REFIT_MOVED_PX = 0.5  # a tag refit that moves the field's corners less than this keeps the rods' placement
EDGE_SAMPLES = 40  # whole balls in view whose colour masks give the mask's edge radius (BallDetector.edge_scale)
FIXTURE_FRAMES = 25  # searches that find a blob at the same pixel before it counts as part of the table
# Where the ball can be seen: the playing field and the goal mouths, with a ball radius of margin. The
# pockets behind the mouths are roofed, so a camera above never sees a ball there, only the roof.
FIELD_HALF_X, FIELD_HALF_Y, GOAL_HALF_X, GOAL_DEPTH = 0.34, 0.60, 0.10, 0.025


def weak_too_long(seconds: float, frames: int, masked: bool = False) -> bool:
    """A track has lived on partial blobs alone for too long (both limits passed)."""
    return seconds > (MASKED_WEAK_TRACK_LIMIT if masked else WEAK_TRACK_LIMIT) and frames > WEAK_TRACK_FRAMES


@dataclass
class TrackerConfig:
    ball_color: str = "auto"
    intrinsics: Optional[Intrinsics] = None
    tag_interval: int = 30  # frames between tag refits once the tags are found (the camera is mounted)
    fovy_hint: float = 50.0  # used only for parallax with tags off the ball plane and no intrinsics
    auto_frames: int = 24  # frames at least used to pick the colour in auto mode
    learn_after: int = 0  # > 0: confident detections before the colour box is re-centred on the ball seen (off:
    # on renders re-centring lost the ball's rim pixels and doubled the median error)
    measurement_std: float = 0.0015
    params_file: Optional[str] = None  # foos_sim table parameters: where the rods are (auto colour); None = nominal


@dataclass
class Detection:
    t: float
    x: float
    y: float
    z: float
    u: float  # pixel centre in the (distorted) image
    v: float
    area_ratio: float


@dataclass
class TrackerStats:
    frames: int = 0
    frames_with_mapping: int = 0
    detections: int = 0
    tag_fits: int = 0
    tags_seen: set = field(default_factory=set)
    rejected_fits: int = 0
    dropped_tags: dict = field(default_factory=dict)  # id -> worst disagreement (m) when left out of a fit
    masked_frames: int = 0  # frames searched with the figure mask (joint positions known)


class BallTracker:
    def __init__(self, layout: MarkerLayout, config: TrackerConfig | None = None,
                 figures: Optional[FigureGeometry] = None):
        """figures: the table's figure boxes; with them, process(..., joints) masks out the figures' pixels."""
        self.layout = layout
        self.figures = figures
        self._masker: Optional[FigureMasker] = None
        self._active_region: Optional[np.ndarray] = None  # the field minus this frame's figures
        self._active_region_small: Optional[np.ndarray] = None
        # With the figure mask: the steel rods' pixels, which are in front of the ball wherever they overlap it. A
        # ball partly behind a rod is measured as a partial view of a whole ball (BallDetector's hidden).
        self._hidden: Optional[np.ndarray] = None
        self._rod_pixels: Optional[np.ndarray] = None
        self._rod_axes: Optional[np.ndarray] = None  # one-pixel line of each rod's axis (rod_lines.rod_axis_mask)
        self._rods_unseen = False  # a rod was not found on its steel when the rods were last placed
        # The field less the rods less a pixel all round, searched with the figure mask: the rods' image is placed
        # within about a pixel, and a white ball's lit edge beside a rod must not be cut off.
        self._region_less_rods: Optional[np.ndarray] = None
        self._projection: Optional[np.ndarray] = None
        self._joints: Optional[np.ndarray] = None  # this frame's, with the figure mask
        self._felt_ab: Optional[tuple[float, float]] = None
        self._placed_for: Optional[PlaneMapping] = None  # the tag fit the rods and the felt's colour were taken at
        self._feet: Optional[np.ndarray] = None  # footprints of the figures' parts below the ball's top, made on demand
        self.config = config or TrackerConfig()
        if self.config.ball_color != "auto" and self.config.ball_color not in BALL_COLOR_NAMES:
            raise ValueError(f"unknown ball colour `{self.config.ball_color}` (auto, {', '.join(BALL_COLOR_NAMES)})")
        self.lens = Lens(self.config.intrinsics)
        self.tags = TagLocator(layout, self.lens)
        self.mapping: Optional[PlaneMapping] = None
        self.last_tag_corners: dict[int, np.ndarray] = {}
        self.last_fit_error: Optional[str] = None
        self.kalman = ConstantVelocityKalman(measurement_std=self.config.measurement_std)
        self.stats = TrackerStats()
        self._frame_size: Optional[tuple[int, int]] = None
        self._region: Optional[np.ndarray] = None
        self._roi = (0, 0, 0, 0)
        self._min_radius = 2.0
        self._auto_seen: dict[str, "MovingBallVotes"] = {}  # per colour, made once the rod bands are known
        self._rods: Optional[RodGeometry] = None
        self._rod_bands: Optional[np.ndarray] = None  # ball-plane y a hanging figure covers, per rod
        self._auto_done = self.config.ball_color != "auto"
        start = "white" if self.config.ball_color == "auto" else self.config.ball_color
        self.detector = BallDetector(colour_model(start))
        self._learn_pixels: list[np.ndarray] = []
        self._whole_ratios: deque = deque(maxlen=EDGE_SAMPLES)  # area ratios of whole balls in plain view
        self._learned = False
        self._last_t: Optional[float] = None
        self._fixtures: dict[tuple[int, int], int] = {}
        self._weak_since: Optional[float] = None
        self._weak_since_frame = 0
        self._confident_run = 0
        self._misses = 0  # frames since the last detection
        self._weak_frames = 0
        self._pending: Optional[tuple[float, float, float]] = None  # (t, u, v) of an unconfirmed new track
        self._partial_history: deque = deque(maxlen=max(1, PARTIAL_RUN))  # (t, [found tuples]) of field searches
        self._partials_now: list = []
        self._radius_grid = np.ones((1, 1))
        self._search_scale = 1.0
        self._region_small: Optional[np.ndarray] = None
        self._field_lab: Optional[np.ndarray] = None
        self.figures_masked = False  # this frame's figures are out of the searched region

    # --- tags -------------------------------------------------------------------------------------
    def _refit(self, bgr: np.ndarray) -> None:
        gray = cv2.cvtColor(bgr, cv2.COLOR_BGR2GRAY)
        centres, corners = self.tags.detect(gray)
        self.stats.tags_seen |= set(centres)
        if corners:
            self.last_tag_corners = corners
        try:
            mapping = fit_mapping(centres, self.layout, (bgr.shape[1], bgr.shape[0]), self.config.intrinsics,
                                  self.config.fovy_hint)
        except MarkersError as error:
            self.last_fit_error = str(error)
            return
        if mapping.residual_m > MAX_TAG_RESIDUAL:
            self.stats.rejected_fits += 1
            # A lens that bends straight lines (a fisheye above all) does this too when it is not undistorted.
            lens_hint = "" if self.config.intrinsics is not None else ", or the lens needs --intrinsics"
            self.last_fit_error = (f"the tags seen are {mapping.residual_m * 1000:.0f} mm (RMS) away from where the "
                                   f"markers file puts them: the file does not describe this table{lens_hint}")
            return
        self.stats.tag_fits += 1
        self.last_fit_error = None
        for tag_id, error in (mapping.dropped or {}).items():
            self.stats.dropped_tags[tag_id] = max(error, self.stats.dropped_tags.get(tag_id, 0.0))
        if self.mapping is None or not np.allclose(mapping.image_to_table, self.mapping.image_to_table, atol=1e-9):
            # A refit that moves the field by a fraction of a pixel is tag noise, not a camera that moved: the rods
            # and the felt's colour are kept (placing the rods costs 12-20 ms).
            moved = self._placed_for is None or self._pixels_moved(self._placed_for, mapping) > REFIT_MOVED_PX
            if moved:
                self._placed_for = mapping
            self.mapping = mapping
            self._update_region(bgr.shape[1], bgr.shape[0])
            if moved or self._rod_pixels is None:
                self._place_rods(bgr)
            else:
                self._cut_rods_from_region()  # the same rods in a field region redrawn by this fit
            if moved or self._felt_ab is None:
                # The felt is most of the field: its median colour (Lab a, b) tells bare felt from everything else.
                field = cv2.cvtColor(np.ascontiguousarray(bgr[::4, ::4]), cv2.COLOR_BGR2Lab)[self._region[::4, ::4] > 0]
                self._felt_ab = (float(np.median(field[:, 1])), float(np.median(field[:, 2])))
        elif self._rods_unseen:
            self._place_rods(bgr)  # a rod not seen on its steel (a hand over it then) is looked for at every tag fit

    def _place_rods(self, bgr: np.ndarray) -> None:
        """The rods' image and axes, each rod placed on the steel seen in this frame (12-20 ms)."""
        size = (bgr.shape[1], bgr.shape[0])
        shifts = fit_rod_shifts(bgr, self._region, self._rods, self._projection, self.lens.distort)
        self._rods_unseen = bool(np.any(np.isnan(shifts)))
        self._rod_pixels = rod_mask(self._rods, self._projection, self.lens.distort, size, shifts)
        self._rod_axes = rod_axis_mask(self._rods, self._projection, self.lens.distort, size, shifts)
        self._cut_rods_from_region()

    def _cut_rods_from_region(self) -> None:
        """The field less the rods less a pixel all round, searched with the figure mask."""
        if self._masker is not None:
            core = cv2.erode(self._rod_pixels, np.ones((3, 3), np.uint8))
            self._region_less_rods = cv2.bitwise_and(self._region, cv2.bitwise_not(core))

    def _pixels_moved(self, old: PlaneMapping, new: PlaneMapping) -> float:
        """How far (px) the field's corners move from one homography to the other."""
        corners = np.array([(sx * FIELD_HALF_X, sy * FIELD_HALF_Y) for sx in (-1, 1) for sy in (-1, 1)])
        return float(np.max(np.linalg.norm(old.to_image(corners) - new.to_image(corners), axis=1)))

    def _update_region(self, width: int, height: int) -> None:
        m = BALL_RADIUS
        x, y, gx, gy = FIELD_HALF_X + m, FIELD_HALF_Y + m, GOAL_HALF_X + m, FIELD_HALF_Y + GOAL_DEPTH
        outline = [(-x, -FIELD_HALF_Y), (-gx, -FIELD_HALF_Y), (-gx, -gy), (gx, -gy), (gx, -FIELD_HALF_Y), (x, -FIELD_HALF_Y),
                   (x, FIELD_HALF_Y), (gx, FIELD_HALF_Y), (gx, gy), (-gx, gy), (-gx, FIELD_HALF_Y), (-x, FIELD_HALF_Y)]
        outline = [(-x, -y)] + outline[1:5] + [(x, -y), (x, y)] + outline[7:11] + [(-x, y)]
        # Densify the edges so that lens distortion bends them as it bends the image.
        dense = []
        for a, b in zip(outline, outline[1:] + outline[:1]):
            for s in np.linspace(0, 1, 12, endpoint=False):
                dense.append((a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])))
        pixels = self.lens.distort(self.mapping.to_image(np.array(dense)))
        region = np.zeros((height, width), np.uint8)
        cv2.fillPoly(region, [np.round(pixels).astype(np.int32)], 255)
        k = self.config.intrinsics.camera_matrix if self.config.intrinsics is not None else None
        projection = projection_from_mapping(self.mapping, (width, height), k, self.config.fovy_hint)
        if self._rods is None:
            self._rods = rod_geometry(self.config.params_file)
        self._region = region
        self._make_radius_grid(width, height)
        ys, xs = np.nonzero(region)
        if len(xs) == 0:
            raise MarkersError("the field lies outside the image according to the tags: check the markers file")
        self._roi = (int(xs.min()), int(ys.min()), int(xs.max()) + 1, int(ys.max()) + 1)
        radii = [self._radius_at_table(p) for p in ((-0.34, -0.6), (0.34, -0.6), (0.34, 0.6), (-0.34, 0.6), (0, 0))]
        self._min_radius = max(1.5, min(radii))
        # Search the whole field at half resolution when even the smallest ball keeps 2.5 px of radius there.
        self._search_scale = 0.5 if self._min_radius >= 5.0 else 1.0
        if self._search_scale != 1.0:
            x0, y0, x1, y1 = self._roi
            self._region_small = cv2.resize(region[y0:y1, x0:x1], None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST)
        self._active_region, self._active_region_small = self._region, self._region_small
        self.figures_masked = False
        if self.figures is not None:
            self._masker = FigureMasker(self.figures, projection, self.lens, (width, height))
        self._projection = projection  # the rods are placed by _refit, on this frame's steel
        self._hidden = None
        self._rod_bands = rod_bands(self._rods, camera_centre(projection))

    def set_figures(self, joints: Optional[np.ndarray]) -> None:
        """Search this frame's field without the figures at these joint positions (16, JOINT_NAMES order);
        None: the whole field, as without joint states."""
        self.figures_masked = joints is not None and self._masker is not None
        if not self.figures_masked:
            self._active_region, self._active_region_small = self._region, self._region_small
            self._hidden = None
            return
        # The rods are left in the search without the figure mask: a figure of the ball's colour half behind its
        # rod would be measured as a whole ball. The figures' footprints are not counted as hiding the ball either:
        # only their parts above the ball's top are masked, and a foot below shows beside its masked body.
        self._hidden = self._rod_pixels
        self._joints, self._feet = np.asarray(joints, float), None
        figures = self._masker.mask(self._joints)
        self._active_region = cv2.bitwise_and(self._region_less_rods, cv2.bitwise_not(figures))
        if self._search_scale != 1.0:
            x0, y0, x1, y1 = self._roi
            self._active_region_small = cv2.resize(self._active_region[y0:y1, x0:x1], None, fx=0.5, fy=0.5,
                                                   interpolation=cv2.INTER_NEAREST)

    @property
    def rod_axes(self) -> Optional[np.ndarray]:
        """uint8 image, 255 on each rod's axis as placed on the steel seen (rods not found left out); None before
        the first tag fit."""
        return self._rod_axes

    @property
    def figures_guarded(self) -> bool:
        """A figure of the ball's colour cannot pass for the ball in this frame: the figures are masked out, or
        the ball is coloured and every rod was found on its steel, so a blob over a rod (a figure's head,
        `_covers_rod`) is dropped. (A figure's legs and feet are not dropped, but joined to its body over the rod
        they start no track, `_starts_track`.)"""
        return self.figures_masked or (self._rods_tell_figures and not self._rods_unseen)

    @property
    def _rods_tell_figures(self) -> bool:
        """The rods are placed and the ball is coloured: what covers a rod in (nearly) its colour is a figure."""
        return self._rod_axes is not None and self.colour.hue_lo is not None

    def figure_mask(self, joints: np.ndarray) -> Optional[np.ndarray]:
        """The figures' footprint (uint8, 255 under a figure) once the tags are found, for drawing."""
        return None if self._masker is None else self._masker.mask(np.asarray(joints, float))

    # --- geometry helpers -------------------------------------------------------------------------
    def _radius_at_table(self, xy) -> float:
        return BALL_RADIUS * self.mapping.pixels_per_metre(np.asarray(xy, float))

    def _radius_at_pixel(self, u: float, v: float) -> float:
        """Expected ball radius in pixels, looked up on a grid made once per homography (it varies slowly)."""
        h, w = self._radius_grid.shape
        i = min(h - 1, max(0, int(v / RADIUS_GRID)))
        j = min(w - 1, max(0, int(u / RADIUS_GRID)))
        return float(self._radius_grid[i, j])

    def _make_radius_grid(self, width: int, height: int) -> None:
        us = (np.arange(0, width, RADIUS_GRID) + RADIUS_GRID / 2).clip(0, width - 1)
        vs = (np.arange(0, height, RADIUS_GRID) + RADIUS_GRID / 2).clip(0, height - 1)
        grid = np.stack(np.meshgrid(us, vs), axis=-1).reshape(-1, 2)
        xy = self.mapping.to_table(self.lens.undistort(grid))
        # Local scale of the table->image map (through the lens) by finite differences on the ball plane.
        d = 2e-3
        p0 = self.lens.distort(self.mapping.to_image(xy))
        px = self.lens.distort(self.mapping.to_image(xy + (d, 0)))
        py = self.lens.distort(self.mapping.to_image(xy + (0, d)))
        jac = np.stack([(px - p0) / d, (py - p0) / d], axis=2)  # (N, 2, 2)
        # A sphere's outline is not foreshortened the way the plane is: its radius follows the plane's
        # larger scale (across the line of sight), not the mean of the two.
        scale = np.linalg.svd(jac, compute_uv=False)[:, 0]
        self._radius_grid = (BALL_RADIUS * scale).reshape(len(vs), len(us))

    def pixel_to_table(self, u: float, v: float) -> np.ndarray:
        return self.mapping.to_table(self.lens.undistort(np.array([[u, v]])))[0]

    def table_to_pixel(self, xy) -> np.ndarray:
        return self.lens.distort(self.mapping.to_image(np.asarray(xy, float).reshape(1, 2)))[0]

    # --- per frame --------------------------------------------------------------------------------
    def process(self, bgr: np.ndarray, t: float, joints: Optional[np.ndarray] = None) -> Optional[Detection]:
        """The ball in this frame, or None (no ball is ever guessed). joints: the 16 rod joint positions at the
        frame's time (JOINT_NAMES order), when known and the tracker has figures: their pixels are not ball."""
        if bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3:
            raise ValueError("the tracker needs 3-channel BGR frames")
        if self._last_t is not None and t < self._last_t:
            raise ValueError(f"frame times go backwards ({t:.6f} s after {self._last_t:.6f} s)")
        self._last_t = t
        size = (bgr.shape[1], bgr.shape[0])
        if self._frame_size not in (None, size):
            self.mapping = self._placed_for = None  # a different camera mode: the old fit means nothing
        self._frame_size = size
        self.stats.frames += 1
        if self.mapping is None or self.stats.frames % self.config.tag_interval == 0:
            self._refit(bgr)
        if self.mapping is None:
            return None
        self.stats.frames_with_mapping += 1
        self.set_figures(joints)
        self.stats.masked_frames += int(joints is not None and self._masker is not None)
        if not self._auto_done:
            self._vote_colour(bgr)
            if not self._auto_done:
                return None  # no colour yet: a guess could be a rod or a hand
        chosen, lab_roi, roi = self._find(bgr, t)
        if chosen is not None and chosen.hidden == 0 and self._solid(chosen, ACQUIRE_SOLID_RATIO):
            # How much of a whole ball the colour mask takes (BallDetector.edge_scale), from the balls seen whole.
            self._whole_ratios.append(chosen.area_ratio)
            if len(self._whole_ratios) >= EDGE_SAMPLES // 2:
                self.detector.edge_scale = float(np.clip(math.sqrt(np.median(self._whole_ratios)), 0.7, 1.0))
        if chosen is None:
            self._misses += 1
            return None
        self._misses = 0
        xy = self.pixel_to_table(chosen.u, chosen.v)
        self.kalman.update(t, xy)
        self.stats.detections += 1
        if self.config.learn_after > 0 and not self._learned and self._auto_done and self._confident(chosen):
            self._collect_colour(lab_roi, roi, chosen)
        return Detection(t, float(xy[0]), float(xy[1]), BALL_CENTRE_HEIGHT, chosen.u, chosen.v, chosen.area_ratio)

    def _confident(self, c: Candidate) -> bool:
        return 0.6 <= c.area_ratio <= 1.5 and c.roundness >= 0.65

    def _find(self, bgr: np.ndarray, t: float):
        predicted = self.kalman.predict(t)
        if predicted is not None:
            found = self._search_near(bgr, predicted, t - self.kalman.state.t, self._misses)
            if found[0] is not None and self._solid(found[0]):
                self._weak_since = None
                self._confident_run = 0
                return found
            if found[0] is not None:
                # Not a whole, round ball where one is expected: a ball behind a rod or a foot, or a figure of
                # the ball's colour that the track slid onto when the ball was picked up. A whole ball
                # elsewhere on the field settles it.
                # (Looked for every few frames only: a whole-field search costs as much as tracking.)
                self._weak_frames += 1
                elsewhere = (self._solid_elsewhere(bgr, found[0]) if self._weak_frames % ELSEWHERE_EVERY == 1
                             else (None, None, None))
                if elsewhere[0] is not None:
                    self.kalman.reset()
                    self._weak_since = None
                    self._confident_run = 0
                    return elsewhere
                # A figure's outline passes for a ball now and then, a ball in view does so frame after
                # frame: only a run of ball-like frames makes a track healthy again.
                # A ball merged with something of its colour is no proof either: the end of a red figure's
                # bar is a ball-sized, roundish blob that goes on past the ball's outline.
                ball_like = self._confident(found[0]) and found[0].spill <= MAX_SPILL
                self._confident_run = self._confident_run + 1 if ball_like else 0
                if self._confident_run >= CONFIDENT_RUN or (ball_like and found[0].fill >= HEALTHY_FILL
                                                            and found[0].roundness >= HEALTHY_ROUNDNESS):
                    self._weak_since = None
                    return found
                # Only part of a ball: good for a while, but a track made of parts alone ends after
                # WEAK_TRACK_LIMIT: it may be a figure of the ball's colour, next to where the ball was
                # picked up.
                if self._weak_since is None:
                    self._weak_since, self._weak_since_frame = t, self.stats.frames
                if not weak_too_long(t - self._weak_since, self.stats.frames - self._weak_since_frame,
                                     self.figures_guarded):
                    return found
                return None, None, None
        self._partials_now = []
        found = self._best_on_field(bgr)
        self._partial_history.append((t, self._partials_now))
        if found[0] is None:
            self._pending = None
            run = self._partial_run()
            if run[0] is not None:
                self._partial_history.clear()
                self._weak_since = None
                self._confident_run = 0
            return run
        # A new track needs a ball-like blob in two frames running, close together: the outline of a
        # figure of a similar colour passes for a ball in a single frame now and then, a ball in view
        # does so frame after frame.
        c, pending = found[0], self._pending
        self._pending = (t, c.u, c.v)
        if self._solid(c, ACQUIRE_SOLID_RATIO):
            pending = (t, c.u, c.v)  # a whole, round, filled disc on its own needs no second look
        elif pending is None or t - pending[0] > ACQUIRE_WINDOW:
            return None, None, None
        radius = self._radius_at_pixel(c.u, c.v)
        reach = radius + MAX_GATE * self.mapping.pixels_per_metre(self.pixel_to_table(c.u, c.v)) * min(1.0, (t - pending[0]) / 0.04)
        if math.hypot(c.u - pending[1], c.v - pending[2]) > reach:
            return None, None, None
        self._pending = None
        self._weak_since = None
        self._confident_run = 0
        return found

    @staticmethod
    def _solid(c: Candidate, min_ratio: float = 0.75) -> bool:
        """A whole ball in plain view: nearly the full disc, round, filled, and not part of a larger blob."""
        return min_ratio <= c.area_ratio <= 1.3 and c.roundness >= 0.8 and c.fill >= 0.85 and c.spill <= MAX_SPILL

    def _solid_elsewhere(self, bgr: np.ndarray, tracked: Candidate):
        """A whole ball away from the tracked blob, found with the shading-tolerant colour (or nothing); not a
        figure's legs (_starts_track)."""
        radius = self._radius_at_pixel(tracked.u, tracked.v)
        loose = [c for c in self._search_field(bgr) if c.area_ratio >= 0.4 and c.roundness >= 0.6
                 and math.hypot(c.u - tracked.u, c.v - tracked.v) >= 3 * radius and not self._fixture(c, count=False)]
        for c in sorted(loose, key=lambda c: -c.score)[:3]:
            r = self._radius_at_pixel(c.u, c.v)
            found = self._search_window(bgr, np.array([c.u, c.v]), 2 * r + 3, 2 * r + 3, use_band=True)
            if (found[0] is not None and self._solid(found[0]) and found[0].score >= tracked.score + 0.15
                    and not self._joined_to_a_covered_rod(bgr, found[0], strict=True)):
                return found
        return None, None, None

    def _starts_track(self, bgr: np.ndarray, c: Candidate) -> bool:
        """Confident, and not merged with something of its colour: the end of a figure's bar is a ball-sized,
        roundish blob too, but it goes on past the ball's outline. Nor joined to a figure of its colour: seen
        from the side, a figure's legs below its rod are a round blob of the ball's size."""
        return self._confident(c) and c.spill <= MAX_SPILL and not self._joined_to_a_covered_rod(bgr, c, strict=True)

    def _best_on_field(self, bgr: np.ndarray):
        candidates = self._search_field(bgr)
        if self._search_scale == 1.0:
            good = [c for c in candidates if self._starts_track(bgr, c) and not self._fixture(c)]
            if not good:
                self._partials_now = [(c, self._field_lab, self._roi) for c in candidates
                                      if self._partial_ball(bgr, c) and not self._fixture(c, count=False)]
            return (max(good, key=lambda c: c.score), self._field_lab, self._roi) if good else (None, None, None)
        # Found at half resolution, where a ball of a few pixels looks less round and smaller than it is: the
        # blobs that nearly pass are measured again on the full-resolution pixels around them, and judged there.
        near_misses = [c for c in candidates if c.area_ratio >= HALF_RES_RATIO and c.roundness >= HALF_RES_ROUNDNESS
                       and not self._fixture(c)]
        for c in sorted(near_misses, key=lambda c: -c.score)[:3]:
            radius = self._radius_at_pixel(c.u, c.v)
            found = self._search_window(bgr, np.array([c.u, c.v]), 2 * radius + 3, 2 * radius + 3)
            if found[0] is not None and self._starts_track(bgr, found[0]):
                return found
            if found[0] is not None and self._partial_ball(bgr, found[0]):
                self._partials_now.append(found)
        return None, None, None

    def _partial_ball(self, bgr: np.ndarray, c: Candidate) -> bool:
        """Part of a ball: enough of the disc, filled (not a figure's hollow outline), not merged with anything, and
        not joined to a figure of its colour (the end of a kicked leg)."""
        return (c.area_ratio >= 0.4 and c.roundness >= 0.5 and c.fill >= MIN_PARTIAL_FILL and c.spill <= MAX_SPILL
                and not self._on_a_foot(c) and not self._joined_to_a_covered_rod(bgr, c))

    def _on_a_foot(self, c: Candidate) -> bool:
        """With the figure mask, the centre of a blob lies on a figure's part below the ball's top. Only the parts
        above are masked (a foot beside the ball can be behind it), so a foot of the ball's colour is still in the
        search: a partial blob centred on one is that foot, or a ball the foot hides the middle of."""
        if not self.figures_masked or self._joints is None:
            return False
        if self._feet is None:
            self._feet = self._masker.mask(self._joints, below=True)
        h, w = self._feet.shape
        return bool(self._feet[min(h - 1, max(0, int(round(c.v)))), min(w - 1, max(0, int(round(c.u))))])

    def _partial_run(self):
        """A new track from PARTIAL_RUN frames running of partial blobs on one steady path (or nothing); only
        where figures are guarded against: a figure sliding with its rod is a partial blob on a steady path too."""
        history = list(self._partial_history)
        if PARTIAL_RUN < 2 or len(history) < PARTIAL_RUN or not self.figures_guarded:
            return None, None, None
        history = history[-PARTIAL_RUN:]
        if any(b[0] - a[0] > ACQUIRE_WINDOW for a, b in zip(history, history[1:])):
            return None, None, None
        for found in history[-1][1]:
            chain = [(history[-1][0], found[0])]
            for t_prev, previous in reversed(history[:-1]):
                t_last, last = chain[-1]
                reach = (self._radius_at_pixel(last.u, last.v) + MAX_GATE * self.mapping.pixels_per_metre(
                    self.pixel_to_table(last.u, last.v)) * min(1.0, (t_last - t_prev) / 0.04))
                near = [f[0] for f in previous if math.hypot(f[0].u - last.u, f[0].v - last.v) <= reach]
                if not near:
                    break
                chain.append((t_prev, min(near, key=lambda c: math.hypot(c.u - last.u, c.v - last.v))))
            if len(chain) < PARTIAL_RUN:
                continue
            ts = np.array([t for t, _ in chain])
            xy = np.array([self.pixel_to_table(c.u, c.v) for _, c in chain])
            design = np.stack([np.ones_like(ts), ts - ts[0]], axis=1)
            coef, *_ = np.linalg.lstsq(design, xy, rcond=None)
            residual = float(np.sqrt(np.mean(np.sum((design @ coef - xy) ** 2, axis=1))))
            if residual <= PARTIAL_RUN_FIT:
                return found
        return None, None, None

    def _search_field(self, bgr: np.ndarray) -> list[Candidate]:
        """Candidates anywhere on the field; at half resolution when the ball is big enough (4x cheaper)."""
        s = self._search_scale
        if s == 1.0:
            candidates, self._field_lab, _ = self.detector.candidates(bgr, self._roi, self._radius_at_pixel,
                                                                      self._min_radius, self._active_region, use_band=False,
                                                                      hidden=self._hidden, felt_ab=self._felt_ab)
            return [c for c in candidates if not self._covers_rod(bgr, c)]
        x0, y0, x1, y1 = self._roi
        small = cv2.resize(bgr[y0:y1, x0:x1], None, fx=s, fy=s, interpolation=cv2.INTER_AREA)
        h, w = small.shape[:2]
        region = self._active_region_small
        # Every blob found here is measured again at full resolution before it counts: no outline fits.
        candidates, _, _ = self.detector.candidates(
            small, (0, 0, w, h), lambda u, v: s * self._radius_at_pixel(x0 + (u + 0.5) / s - 0.5, y0 + (v + 0.5) / s - 0.5),
            s * self._min_radius, region, use_band=False, fit_outline=False)
        for c in candidates:
            c.u, c.v = x0 + (c.u + 0.5) / s - 0.5, y0 + (c.v + 0.5) / s - 0.5
        return candidates

    def _search_window(self, bgr: np.ndarray, centre: np.ndarray, gate: float, half: float, use_band: bool = False,
                       band_seeds: bool = False, partial_reach: float = 0.0):
        """The best candidate within gate px of centre, searched in a square of half width half. Blobs that
        score too low for a ball count only within partial_reach px (a half ball where one is expected)."""
        h, w = bgr.shape[:2]
        x0, y0 = max(0, int(centre[0] - half)), max(0, int(centre[1] - half))
        x1, y1 = min(w, int(centre[0] + half) + 1), min(h, int(centre[1] + half) + 1)
        if x1 - x0 < 3 or y1 - y0 < 3:
            return None, None, None
        roi = (x0, y0, x1, y1)
        candidates, lab, _ = self.detector.candidates(bgr, roi, self._radius_at_pixel, self._min_radius, self._active_region,
                                                      use_band=use_band, band_seeds=band_seeds, hidden=self._hidden,
                                                      felt_ab=self._felt_ab)
        near = [c for c in candidates if math.hypot(c.u - centre[0], c.v - centre[1]) <= gate
                and (c.score > MIN_SCORE or (c.score > PARTIAL_MIN_SCORE and c.area_ratio >= PARTIAL_MIN_RATIO
                                             and math.hypot(c.u - centre[0], c.v - centre[1]) <= partial_reach))
                and not self._covers_rod(bgr, c)]
        if not near:
            return None, lab, roi
        best = min(near, key=lambda c: math.hypot(c.u - centre[0], c.v - centre[1]) / gate - c.score)
        return best, lab, roi

    def _covers_rod(self, bgr: np.ndarray, c: Candidate) -> bool:
        """The blob lies over a rod's axis, in the ball's colour: a figure of that colour (or anything else above
        the rods), not the ball, which the rods are always in front of."""
        if not self._rods_tell_figures:
            return False
        radius = self._radius_at_pixel(c.u, c.v)
        reach = ROD_COVER_RADIUS * radius
        x0, y0, x1, y1 = self._window_around(c, reach)
        ys, xs = np.nonzero(self._rod_axes[y0:y1, x0:x1])
        xs, ys = xs + x0, ys + y0
        squared = (xs - c.u) ** 2 + (ys - c.v) ** 2
        inside = squared <= reach * reach
        if np.count_nonzero(inside) < 2:
            return False
        # Only the axis beside the blob's centre, within ROD_COVER_ALONG radii along the rod of the nearest axis
        # point: a figure's head has its middle there and covers only part of the chord within reach.
        inside &= squared <= squared[inside].min() + (ROD_COVER_ALONG * radius) ** 2
        coloured = self._near_ball_colour(np.ascontiguousarray(bgr[ys[inside], xs[inside]][:, None, :]))
        return bool(np.count_nonzero(coloured) >= max(2, ROD_COVER_SHARE * len(coloured)))

    def _window_around(self, c: Candidate, reach: float) -> tuple[int, int, int, int]:
        """(x0, y0, x1, y1) of the frame's pixels within reach of the candidate's centre, clipped to the frame."""
        h, w = self._rod_axes.shape
        return (max(0, int(c.u - reach)), max(0, int(c.v - reach)),
                min(w, int(c.u + reach) + 2), min(h, int(c.v + reach) + 2))

    def _near_ball_colour(self, bgr: np.ndarray) -> np.ndarray:
        """Pixels of a colour near the ball's and not grey like the steel (bool, the image's shape less its
        channels): a red figure passes for an orange ball by its orange-lit edges only, so the box is wider."""
        ab = cv2.cvtColor(bgr, cv2.COLOR_BGR2Lab)[..., 1:].astype(np.int16)
        model = self.colour
        near = ((np.abs(ab[..., 0] - model.a) <= ROD_COVER_AB * model.ab_tol)
                & (np.abs(ab[..., 1] - model.b) <= ROD_COVER_AB * model.ab_tol))
        if self._felt_ab is not None:
            # The wider box reaches the green felt's lighter threads from a yellow ball: nearer the felt is felt.
            a, b = ab[..., 0].astype(np.float32), ab[..., 1].astype(np.float32)
            to_ball = (a - model.a) ** 2 + (b - model.b) ** 2
            to_felt = (a - self._felt_ab[0]) ** 2 + (b - self._felt_ab[1]) ** 2
            near &= to_ball < to_felt
        return near & (np.maximum(np.abs(ab[..., 0] - 128), np.abs(ab[..., 1] - 128)) > 1.5 * STEEL_AB_TOL)

    def _joined_to_a_covered_rod(self, bgr: np.ndarray, c: Candidate, strict: bool = False) -> bool:
        """Pixels of (nearly) the ball's colour join the blob to a stretch of rod axis they cover: the blob is part
        of a figure of that colour (the end of a kicked leg, a foot), or touches one. strict: pixels of the ball's
        own colour model only; a whole ball in front of a red figure's foot is joined to it in nearly an orange
        ball's colour, while an orange figure's legs are one piece of the ball's colour with its body."""
        if not self._rods_tell_figures:
            return False
        radius = self._radius_at_pixel(c.u, c.v)
        x0, y0, x1, y1 = self._window_around(c, FIGURE_REACH * radius)
        axes = self._rod_axes[y0:y1, x0:x1] > 0
        if not np.any(axes):
            return False
        window = np.ascontiguousarray(bgr[y0:y1, x0:x1])
        if strict:
            coloured = (self.colour.mask(cv2.cvtColor(window, cv2.COLOR_BGR2Lab), window) > 0).astype(np.uint8)
        else:
            coloured = self._near_ball_colour(window).astype(np.uint8)
        _, labels = cv2.connectedComponents(coloured, connectivity=8)
        ys, xs = np.nonzero(labels)
        own = labels[ys, xs][(xs + x0 - c.u) ** 2 + (ys + y0 - c.v) ** 2 <= radius * radius]
        if len(own) == 0:
            return False
        blob = np.bincount(own).argmax()
        # A figure's leg or foot lies straight across its rod from the body that covers the axis; a ball beside a
        # figure along the rod is a ball. So the middle of the covered stretch it is joined to must be in line.
        _, lines = cv2.connectedComponents(axes.astype(np.uint8), connectivity=8)
        ay, ax = np.nonzero(axes)
        offsets = np.column_stack([ax + x0 - c.u, ay + y0 - c.v]).astype(float)
        line, joined = lines[ay, ax], labels[ay, ax] == blob
        for rod in np.unique(line[joined]):
            on_rod = line == rod
            if np.count_nonzero(joined & on_rod) < 2:
                continue
            # The rod's direction here: the principal axis of its pixels in the window.
            spread = np.cov(offsets[on_rod].T)
            direction = np.linalg.eigh(spread)[1][:, -1]
            if abs(float(np.mean(offsets[joined & on_rod] @ direction))) <= FIGURE_ALONG * radius:
                return True
        return False

    def _fixture(self, c: Candidate, count: bool = True) -> bool:
        """A ball-like blob that sits at the same pixel frame after frame, while no ball is tracked, is part of
        the table (a screw head, a sticker, a lamp's reflection), not the ball."""
        cell = (int(c.u // 3), int(c.v // 3))
        seen = self._fixtures.get(cell, 0) + (1 if count else 0)
        self._fixtures[cell] = seen
        return seen > FIXTURE_FRAMES

    def _search_near(self, bgr: np.ndarray, state: KalmanState, coast: float = 0.0, coast_frames: int = 0):
        ppm = self.mapping.pixels_per_metre(state.x[:2])
        radius = BALL_RADIUS * ppm
        sigma = math.sqrt(max(np.linalg.eigvalsh(state.P[:2, :2]).max(), 0.0)) * ppm
        # While the ball is hidden it may be hit (a foot, a wall): the longer the track coasts, the further
        # from the prediction a whole ball may reappear.
        gate = min(4.0 * sigma + COAST_SPEED * coast * ppm, MAX_GATE * ppm) + 1.5 * radius + 2.0
        centre = self.table_to_pixel(state.x[:2])
        found, lab, roi = self._search_window(bgr, centre, gate, gate + 2 * radius + 2, use_band=True,
                                              band_seeds=BAND_SEEDS_NEAR,
                                              partial_reach=PARTIAL_NEAR * radius + 2.0 * sigma)
        offset = math.inf if found is None else math.hypot(found.u - centre[0], found.v - centre[1])
        if found is not None and found.spill > MAX_SPILL and (coast_frames > 0 or offset > PARTIAL_NEAR * radius
                                                                + 2.0 * sigma):
            # Merged with something of its colour (a ball against a figure, or a figure's bar alone): its centre
            # is pulled toward the figure, so it only carries a track that has not lost the ball, and only
            # where the ball is expected. A coasting track would slide onto the figure.
            return None, lab, roi
        if found is not None and not self._solid(found) and self._on_a_foot(found):
            return None, lab, roi
        if found is not None and not self._confident(found):
            # A partly hidden ball is followed only where it is expected; further out, only a whole ball
            # counts, so a figure of the ball's colour cannot take the track over.
            if offset > min(gate, 2.0 * radius + 2 * sigma + 2.0):
                return None, lab, roi
            # After the ball has been lost for a few frames, the outline of a figure (its edge pixels blend
            # into the ball's hue) must not restart the track: it is a thin ring with little inside, while a
            # ball coming out from under a foot shows a solid part. (A rod across a tracked ball's middle
            # also empties its inside, so this holds only while coasting.)
            if coast_frames >= 2 and found.fill < MIN_PARTIAL_FILL:
                return None, lab, roi
        # Nor may a track that has lost the ball go on with a figure of its colour, joined in (nearly) that
        # colour to the rod it covers: the end of a kicked leg (the hands video: the leg beside the hand that had
        # just picked the ball up), or, seen from the side, the legs below the rod. Not before the ball is lost:
        # a ball touching a figure of its colour is that too (applied in every frame: recall -1 to -7 points in
        # six red and orange videos).
        if found is not None and coast_frames >= 1 and self._joined_to_a_covered_rod(bgr, found,
                                                                                  strict=self._confident(found)):
            return None, lab, roi
        return found, lab, roi

    # --- colour -------------------------------------------------------------------------------------
    def _vote_colour(self, bgr: np.ndarray) -> None:
        """Auto colour: which prototype finds one round, ball-sized blob that moves, most often."""
        for name in BALL_COLOR_NAMES:
            detector = BallDetector(colour_model(name))
            candidates, _, _ = detector.candidates(bgr, self._roi, self._radius_at_pixel, self._min_radius,
                                                   self._active_region,
                                                   use_band=False)
            if name not in self._auto_seen:
                self._auto_seen[name] = MovingBallVotes()
            self._auto_seen[name].bands = self._rod_bands  # the latest tag fit's
            self._auto_seen[name].add([(c.u, c.v, *self.pixel_to_table(c.u, c.v))
                                       for c in candidates if self._confident(c)])
        votes = {name: self._auto_seen[name].votes() for name in BALL_COLOR_NAMES}
        ranked = sorted(BALL_COLOR_NAMES, key=lambda n: -votes[n])
        best, second = ranked[0], ranked[1]
        if votes[best] > 0:
            self.detector = BallDetector(colour_model(best))
        # Settle only on clear evidence: a figure of one colour passes for a ball now and then (a red figure
        # moving with its rod in a fifth of the frames while an orange ball was half hidden), a ball in view
        # does so in most frames.
        voted = self._auto_seen[best].frames
        if (self.stats.frames_with_mapping >= self.config.auto_frames and votes[best] >= max(3, AUTO_MIN_SHARE * voted)
                and votes[best] >= 2 * votes[second]):
            self._auto_done = True
            self.kalman.reset()

    @property
    def colour(self) -> ColourModel:
        return self.detector.model

    def _collect_colour(self, lab: np.ndarray, roi, c: Candidate) -> None:
        x0, y0 = roi[0], roi[1]
        r = 0.6 * self._radius_at_pixel(c.u, c.v)
        u, v = c.u - x0, c.v - y0
        ys, xs = np.mgrid[0:lab.shape[0], 0:lab.shape[1]]
        core = (xs - u) ** 2 + (ys - v) ** 2 <= r * r
        pixels = lab[core]
        if len(pixels):
            self._learn_pixels.append(pixels)
        if len(self._learn_pixels) >= self.config.learn_after:
            self.detector = BallDetector(learn_colour(self.detector.model, np.concatenate(self._learn_pixels)),
                                         self.detector.edge_scale)
            self._learned = True


class MovingBallVotes:
    """Auto colour's count for one colour: frames with exactly one blob (u, v pixels, x, y on the ball plane)
    that is neither a fixture nor a figure, over the last AUTO_WINDOW frames.

    A fixture: a blob found again at the same pixel (2 px) in a frame at least 6 frames away (part of the
    table, or a figure at rest). A figure sliding with its rod: a blob inside a rod's band (rod_lines) found
    again, 6 or more frames away, on the same line of y (ROD_LINE_Y_TOL) at another x (ROD_LINE_MIN_DX): a
    figure's ball-plane y stays on its rod's line, a ball's does not. Each blob keeps a count of the blobs in
    the window that make it a fixture or a figure, so a frame costs one comparison with the window, not a
    comparison of every pair (a live feed may wait long for its ball).
    """

    APART = 6  # frames

    def __init__(self, bands: Optional[np.ndarray] = None, window: int = AUTO_WINDOW):
        self.bands, self.window = bands, window
        self.frames = 0  # frames in the window
        self._first = 0  # index of the window's first frame
        self._frame = np.zeros(0, dtype=int)
        self._blob = np.zeros((0, 4))
        self._on_line = np.zeros(0, dtype=bool)
        self._static = np.zeros(0, dtype=int)  # blobs in the window at this blob's pixel
        self._along = np.zeros(0, dtype=int)  # blobs in the window on this blob's line of y, elsewhere in x

    def _matches(self, blobs: np.ndarray, frame: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(len(blobs), N) fixture and rod-line matches of `blobs` (in frames `frame`) with the window's blobs."""
        apart = np.abs(frame[:, None] - self._frame[None, :]) >= self.APART
        same_pixel = np.hypot(blobs[:, None, 0] - self._blob[None, :, 0], blobs[:, None, 1] - self._blob[None, :, 1]) < 2.0
        along = ((np.abs(blobs[:, None, 3] - self._blob[None, :, 3]) < ROD_LINE_Y_TOL)
                 & (np.abs(blobs[:, None, 2] - self._blob[None, :, 2]) >= ROD_LINE_MIN_DX))
        return apart & same_pixel, apart & along

    def add(self, blobs: list[tuple[float, float, float, float]]) -> None:
        """The next frame's blobs."""
        index = self._first + self.frames
        if self.frames == self.window:
            leaving = self._frame == self._first
            static, along = self._matches(self._blob[leaving], self._frame[leaving])
            keep = ~leaving
            self._static = (self._static - static.sum(0))[keep]
            self._along = (self._along - along.sum(0))[keep]
            self._frame, self._blob, self._on_line = self._frame[keep], self._blob[keep], self._on_line[keep]
            self._first += 1
        else:
            self.frames += 1
        new = np.array(blobs, dtype=float).reshape(-1, 4)
        frame = np.full(len(new), index)
        static, along = self._matches(new, frame)
        self._static = np.concatenate([self._static + static.sum(0), static.sum(1)])
        self._along = np.concatenate([self._along + along.sum(0), along.sum(1)])
        on_line = (np.array([on_rod_line(y, self.bands) for y in new[:, 3]], dtype=bool) if self.bands is not None
                   else np.zeros(len(new), dtype=bool))
        self._frame = np.concatenate([self._frame, frame])
        self._blob = np.concatenate([self._blob, new])
        self._on_line = np.concatenate([self._on_line, on_line])

    def votes(self) -> int:
        moving = (self._static == 0) & ~(self._on_line & (self._along > 0))
        per_frame = np.bincount(self._frame[moving] - self._first, minlength=self.frames)
        return int(np.sum(per_frame == 1))


def choose_colour(frames, layout: MarkerLayout, config: TrackerConfig | None = None, fps: float = 30.0,
                  figures: Optional[FigureGeometry] = None, joints_at=None) -> Optional[str]:
    """The ball colour `auto` settles on over these frames (None when it cannot tell), so an offline run
    can track its first frames with the right colour too. joints_at(t): the rod joints at a frame's time
    (or None), to leave the figures out of the vote."""
    config = config or TrackerConfig()
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto", intrinsics=config.intrinsics,
                                                tag_interval=config.tag_interval, fovy_hint=config.fovy_hint,
                                                auto_frames=config.auto_frames, params_file=config.params_file),
                          figures)
    for k, frame in enumerate(frames):
        tracker.process(frame, k / fps, joints_at(k / fps) if joints_at is not None else None)
        if tracker._auto_done:
            return tracker.colour.name
    return None
