"""The field as the camera sees it: the tag fit or the field's corners given (the ball-plane homography), the
region searched for the ball, the rods placed on the steel seen, this frame's figures masked out, and the ball's
expected radius in pixels.

The table's dimensions are the parameter file's (foos_core.table_geometry; the regulation table by default),
the rods' and figures' too (rod_lines.rod_geometry). A tag refit that moves the field by less than
REFIT_MOVED_PX keeps the rods' placement and the felt's colour: that is tag noise, not a camera that moved.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Optional

import cv2
import numpy as np

from foos_core.camera_model import Intrinsics
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params

from ..errors import MarkersError
from .corner_refine import CornerRefinement, refine_field_corners
from .field_corners import FieldCorners, FieldReference
from .figure_mask import FigureGeometry, FigureMasker, projection_from_mapping
from .geometry import (
    MAX_TAG_RESIDUAL,
    Lens,
    PlaneMapping,
    TagLocator,
    corner_camera_matrix,
    corner_focal,
    fit_field_corners,
    fit_mapping,
)
from .rod_lines import camera_centre, fit_rod_shifts, rod_axis_mask, rod_bands, rod_geometry, rod_mask

RADIUS_GRID = 16  # px, spacing of the expected-radius lookup
REFIT_MOVED_PX = 0.5  # a tag refit that moves the field's corners less than this keeps the rods' placement
# Where the ball can be seen: the playing field and the goal mouths, with a ball radius of margin. The pockets
# behind the mouths are roofed, so a camera above never sees a ball there, only the roof: the searched outline
# reaches this far (m) past each goal line into its mouth.
MOUTH_DEPTH_SEEN = 0.025


@dataclass
class TagFitStats:
    """What the tag fits saw, counted by FieldView.refit for the tracker's report (tracker.TrackerStats adds
    its own counts to these)."""
    tag_fits: int = 0
    tags_seen: set = field(default_factory=set)
    rejected_fits: int = 0
    dropped_tags: dict = field(default_factory=dict)  # id -> worst disagreement (m) when left out of a fit


class FieldView:
    """What the latest tag fit says about the image: where the field is, where the rods and (with joint
    positions) the figures are, and how large the ball looks at any pixel. Updated by refit() and, per frame,
    by set_figures()."""

    def __init__(self, layout: FieldReference, params_file: Optional[str], intrinsics: Optional[Intrinsics],
                 fovy_hint: float, stats: TagFitStats, figures: Optional[FigureGeometry] = None):
        """layout: the markers file's tags, or the field's corners in the image (a camera that does not move);
        params_file, intrinsics, fovy_hint: as in tracker.TrackerConfig; stats: counted into by refit()."""
        self.layout, self.stats, self.figures = layout, stats, figures
        self.intrinsics, self.fovy_hint = intrinsics, fovy_hint
        self.table = TableGeometry.of(params_file)
        self.rods = rod_geometry(params_file)
        walls = load_params(params_file)["field"]
        self._wall = (float(walls["wall_height"]), float(walls["wall_thickness"]))  # the walls' top edges, corner_refine
        self.lens = Lens(intrinsics)
        self.corners: Optional[FieldCorners] = layout if isinstance(layout, FieldCorners) else None
        self.tags = TagLocator(layout, self.lens) if self.corners is None else None
        self._corner_mapping: Optional[tuple[tuple[int, int], PlaneMapping]] = None  # (image size, its fit)
        self.corner_refinement: Optional[CornerRefinement] = None  # the corners as fitted to the table's edges
        self._corner_camera: Optional[np.ndarray] = None  # the camera matrix the corners reveal (or the hint's)
        self.mapping: Optional[PlaneMapping] = None
        self.last_tag_corners: dict[int, np.ndarray] = {}
        self.last_fit_error: Optional[str] = None
        self.region: Optional[np.ndarray] = None  # uint8, 255 where the ball can be seen
        self.roi = (0, 0, 0, 0)  # (x0, y0, x1, y1) around the region
        self.min_radius = 2.0  # px, the smallest the ball looks on the field
        self.search_scale = 1.0  # the whole field is searched at this scale (0.5 where the ball is big enough)
        self.region_small: Optional[np.ndarray] = None  # the region's roi at search_scale
        # This frame's search: the field less the figures (with the figure mask), at full and at search scale.
        self.active_region: Optional[np.ndarray] = None
        self.active_region_small: Optional[np.ndarray] = None
        self.figures_masked = False  # this frame's figures are out of the searched region
        # With the figure mask: the steel rods' pixels, which are in front of the ball wherever they overlap it. A
        # ball partly behind a rod is measured as a partial view of a whole ball (BallDetector's hidden).
        self.hidden: Optional[np.ndarray] = None
        self.rod_pixels: Optional[np.ndarray] = None
        self.rod_axes: Optional[np.ndarray] = None  # one-pixel line of each rod's axis (rod_lines.rod_axis_mask)
        self.rods_unseen = False  # a rod was not found on its steel when the rods were last placed
        self.rod_bands: Optional[np.ndarray] = None  # ball-plane y a hanging figure covers, per rod
        self.felt_ab: Optional[tuple[float, float]] = None  # the felt's median Lab (a, b)
        # The field less the rods less a pixel all round, searched with the figure mask: the rods' image is placed
        # within about a pixel, and a white ball's lit edge beside a rod must not be cut off.
        self._region_less_rods: Optional[np.ndarray] = None
        self._projection: Optional[np.ndarray] = None
        self._masker: Optional[FigureMasker] = None
        self._placed_for: Optional[PlaneMapping] = None  # the tag fit the rods and the felt's colour were taken at
        self._joints: Optional[np.ndarray] = None  # this frame's, with the figure mask
        self._feet: Optional[np.ndarray] = None  # footprints of the figures' parts below the ball's top, made on demand
        self._radius_grid = np.ones((1, 1))
        self._frame_size: Optional[tuple[int, int]] = None

    def use_frame_size(self, size: tuple[int, int]) -> None:
        """(width, height) of the next frame: a different camera mode makes the old fit mean nothing."""
        if self._frame_size not in (None, size):
            self.mapping = self._placed_for = None
        self._frame_size = size

    # --- tags or corners ---------------------------------------------------------------------------
    def refit(self, bgr: np.ndarray) -> None:
        """Fit the homography to the tags in this frame, or to the field's corners given; a fit the tags disagree
        with is refused (last_fit_error says why) and the previous one kept. Corners outside this frame:
        FieldCornersError."""
        mapping = self._corner_fit(bgr) if self.corners is not None else self._tag_fit(bgr)
        if mapping is not None:
            self._adopt(mapping, bgr)

    def _corner_fit(self, bgr: np.ndarray) -> PlaneMapping:
        """The mapping the field's corners give, fitted to the table's edges in the first frame of each image size
        (the camera does not move)."""
        size = (bgr.shape[1], bgr.shape[0])
        if self._corner_mapping is None or self._corner_mapping[0] != size:
            self.corners.check_in_image(*size)
            t, intrinsics, hint = self.table, self.intrinsics, self.fovy_hint
            given = self.lens.undistort(self.corners.pixels)
            camera = corner_camera_matrix(given, t.half_width, t.half_length, size, intrinsics, hint)
            focal_known = intrinsics is not None or corner_focal(given, t.half_width, t.half_length, size) is not None
            self.corner_refinement = refine_field_corners(bgr, self.corners.pixels, self.lens, camera, focal_known,
                                                          self.rods, t.half_width, t.half_length, t.goal_half_width,
                                                          *self._wall)
            refined = self.lens.undistort(self.corner_refinement.pixels)
            self._corner_camera = corner_camera_matrix(refined, t.half_width, t.half_length, size, intrinsics, hint)
            mapping = fit_field_corners(refined, t.half_width, t.half_length, t.ball_centre_height, size, intrinsics,
                                        hint)
            self._corner_mapping = (size, mapping)
            self.stats.tag_fits += 1
        return self._corner_mapping[1]

    def _tag_fit(self, bgr: np.ndarray) -> Optional[PlaneMapping]:
        centres, corners = self.tags.locate(bgr)
        self.stats.tags_seen |= set(centres)
        if corners:
            self.last_tag_corners = corners
        try:
            mapping = fit_mapping(centres, self.layout, (bgr.shape[1], bgr.shape[0]), self.intrinsics,
                                  self.fovy_hint)
        except MarkersError as error:
            self.last_fit_error = str(error)
            return None
        if mapping.residual_m > MAX_TAG_RESIDUAL:
            self.stats.rejected_fits += 1
            # A lens that bends straight lines (a fisheye above all) does this too when it is not undistorted.
            lens_hint = "" if self.intrinsics is not None else ", or the lens needs --intrinsics"
            self.last_fit_error = (f"the tags seen are {mapping.residual_m * 1000:.0f} mm (RMS) away from where the "
                                   f"markers file puts them: the file does not describe this table{lens_hint}")
            return None
        self.stats.tag_fits += 1
        self.last_fit_error = None
        for tag_id, error in (mapping.dropped or {}).items():
            self.stats.dropped_tags[tag_id] = max(error, self.stats.dropped_tags.get(tag_id, 0.0))
        return mapping

    def _adopt(self, mapping: PlaneMapping, bgr: np.ndarray) -> None:
        """Take this fit's mapping: the field region, the rods on this frame's steel and the felt's colour."""
        if self.mapping is None or not np.allclose(mapping.image_to_table, self.mapping.image_to_table, atol=1e-9):
            # A refit that moves the field by a fraction of a pixel is tag noise, not a camera that moved: the rods
            # and the felt's colour are kept (placing the rods costs 12-20 ms).
            moved = self._placed_for is None or self._pixels_moved(self._placed_for, mapping) > REFIT_MOVED_PX
            if moved:
                self._placed_for = mapping
            self.mapping = mapping
            self._update_region(bgr.shape[1], bgr.shape[0])
            if moved or self.rod_pixels is None:
                self._place_rods(bgr)
            else:
                self._cut_rods_from_region()  # the same rods in a field region redrawn by this fit
            if moved or self.felt_ab is None:
                # The felt is most of the field: its median colour (Lab a, b) tells bare felt from everything else.
                field = cv2.cvtColor(np.ascontiguousarray(bgr[::4, ::4]), cv2.COLOR_BGR2Lab)[self.region[::4, ::4] > 0]
                self.felt_ab = (float(np.median(field[:, 1])), float(np.median(field[:, 2])))
        elif self.rods_unseen:
            self._place_rods(bgr)  # a rod not seen on its steel (a hand over it then) is looked for at every tag fit

    def _pixels_moved(self, old: PlaneMapping, new: PlaneMapping) -> float:
        """How far (px) the field's corners move from one homography to the other."""
        t = self.table
        corners = np.array([(sx * t.half_width, sy * t.half_length) for sx in (-1, 1) for sy in (-1, 1)])
        return float(np.max(np.linalg.norm(old.to_image(corners) - new.to_image(corners), axis=1)))

    def _outline(self) -> list[tuple[float, float]]:
        """The field and the goal mouths with a ball radius of margin (table frame, m), around the field."""
        t = self.table
        m, hy = t.ball_radius, t.half_length
        x, y, gx, gy = t.half_width + m, hy + m, t.goal_half_width + m, hy + MOUTH_DEPTH_SEEN
        return [(-x, -y), (-gx, -hy), (-gx, -gy), (gx, -gy), (gx, -hy), (x, -y),
                (x, y), (gx, hy), (gx, gy), (-gx, gy), (-gx, hy), (-x, y)]

    def _update_region(self, width: int, height: int) -> None:
        outline = self._outline()
        # Densify the edges so that lens distortion bends them as it bends the image.
        dense = []
        for a, b in zip(outline, outline[1:] + outline[:1]):
            for s in np.linspace(0, 1, 12, endpoint=False):
                dense.append((a[0] + s * (b[0] - a[0]), a[1] + s * (b[1] - a[1])))
        pixels = self.lens.distort(self.mapping.to_image(np.array(dense)))
        region = np.zeros((height, width), np.uint8)
        cv2.fillPoly(region, [np.round(pixels).astype(np.int32)], 255)
        k = self.intrinsics.camera_matrix if self.intrinsics is not None else self._corner_camera
        projection = projection_from_mapping(self.mapping, (width, height), k, self.fovy_hint)
        self.region = region
        self._make_radius_grid(width, height)
        x, y, w, h = cv2.boundingRect(region)  # of its non-zero pixels
        if w == 0:
            raise MarkersError("the field lies outside the image according to the tags: check the markers file")
        self.roi = (x, y, x + w, y + h)
        t = self.table
        corners = ((-t.half_width, -t.half_length), (t.half_width, -t.half_length), (t.half_width, t.half_length),
                   (-t.half_width, t.half_length), (0, 0))
        self.min_radius = max(1.5, min(self.radius_at_table(p) for p in corners))
        # Search the whole field at half resolution when even the smallest ball keeps 2.5 px of radius there.
        self.search_scale = 0.5 if self.min_radius >= 5.0 else 1.0
        if self.search_scale != 1.0:
            x0, y0, x1, y1 = self.roi
            self.region_small = cv2.resize(region[y0:y1, x0:x1], None, fx=0.5, fy=0.5, interpolation=cv2.INTER_NEAREST)
        self.active_region, self.active_region_small = self.region, self.region_small
        self.figures_masked = False
        if self.figures is not None:
            self._masker = FigureMasker(self.figures, projection, self.lens, (width, height))
        self._projection = projection  # the rods are placed by refit, on this frame's steel
        self.hidden = None
        self.rod_bands = rod_bands(self.rods, camera_centre(projection))

    # --- rods -------------------------------------------------------------------------------------
    def _place_rods(self, bgr: np.ndarray) -> None:
        """The rods' image and axes, each rod placed on the steel seen in this frame (12-20 ms)."""
        size = (bgr.shape[1], bgr.shape[0])
        shifts = fit_rod_shifts(bgr, self.region, self.rods, self._projection, self.lens.distort)
        self.rods_unseen = bool(np.any(np.isnan(shifts)))
        self.rod_pixels = rod_mask(self.rods, self._projection, self.lens.distort, size, shifts)
        self.rod_axes = rod_axis_mask(self.rods, self._projection, self.lens.distort, size, shifts)
        self._cut_rods_from_region()

    def _cut_rods_from_region(self) -> None:
        """The field less the rods less a pixel all round, searched with the figure mask."""
        if self._masker is not None:
            core = cv2.erode(self.rod_pixels, np.ones((3, 3), np.uint8))
            self._region_less_rods = cv2.bitwise_and(self.region, cv2.bitwise_not(core))

    # --- figures ----------------------------------------------------------------------------------
    def set_figures(self, joints: Optional[np.ndarray]) -> None:
        """Search this frame's field without the figures at these joint positions (16, JOINT_NAMES order);
        None: the whole field, as without joint states."""
        self.figures_masked = joints is not None and self._masker is not None
        if not self.figures_masked:
            self.active_region, self.active_region_small = self.region, self.region_small
            self.hidden = None
            return
        # The rods are left in the search without the figure mask: a figure of the ball's colour half behind its
        # rod would be measured as a whole ball. The figures' footprints are not counted as hiding the ball either:
        # only their parts above the ball's top are masked, and a foot below shows beside its masked body.
        self.hidden = self.rod_pixels
        self._joints, self._feet = np.asarray(joints, float), None
        figures = self._masker.mask(self._joints)
        self.active_region = cv2.bitwise_and(self._region_less_rods, cv2.bitwise_not(figures))
        if self.search_scale != 1.0:
            x0, y0, x1, y1 = self.roi
            self.active_region_small = cv2.resize(self.active_region[y0:y1, x0:x1], None, fx=0.5, fy=0.5,
                                                  interpolation=cv2.INTER_NEAREST)

    def feet(self) -> Optional[np.ndarray]:
        """With the figure mask, this frame's footprints of the figures' parts below the ball's top (uint8, made on
        the first call of the frame); None without the mask."""
        if not self.figures_masked or self._joints is None:
            return None
        if self._feet is None:
            self._feet = self._masker.mask(self._joints, below=True)
        return self._feet

    # --- pixels and the ball plane ----------------------------------------------------------------
    def radius_at_table(self, xy) -> float:
        return self.table.ball_radius * self.mapping.pixels_per_metre(np.asarray(xy, float))

    def radius_at_pixel(self, u: float, v: float) -> float:
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
        (a, c), (b, e) = ((px - p0) / d).T, ((py - p0) / d).T  # the Jacobian [[a, b], [c, e]] at each point
        # A sphere's outline is not foreshortened the way the plane is: its radius follows the plane's
        # larger scale (across the line of sight), not the mean of the two: the Jacobian's larger singular value,
        # in closed form for 2x2 (an SVD per grid point cost 15 ms at 1080p).
        half_norm = (a * a + b * b + c * c + e * e) / 2
        scale = np.sqrt(half_norm + np.sqrt(np.maximum(half_norm * half_norm - (a * e - b * c) ** 2, 0.0)))
        self._radius_grid = (self.table.ball_radius * scale).reshape(len(vs), len(us))

    def pixel_to_table(self, u: float, v: float) -> np.ndarray:
        return self.mapping.to_table(self.lens.undistort(np.array([[u, v]])))[0]

    def table_to_pixel(self, xy) -> np.ndarray:
        return self.lens.distort(self.mapping.to_image(np.asarray(xy, float).reshape(1, 2)))[0]
