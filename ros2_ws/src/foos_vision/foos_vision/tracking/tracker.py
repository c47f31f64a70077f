"""The tracker: frames in, ball positions in the table frame out (ROS-free; the node and CLI wrap it).

Per frame, BallTracker.process: the tags (field_view: homography, field region, rods on the steel seen, the
figures at this frame's joints), the ball's colour while `auto` has not settled it (ball_colour), then the ball:
near the track's prediction, else anywhere on the field (ball_search), each blob judged by the candidate rules
(candidate_rules). What is kept here is the track's own state: how long it has lived on partial blobs, the
sighting that waits for a second one, the frames since the last detection.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Optional, Union

import numpy as np

from foos_core.camera_model import Intrinsics
from foos_core.markers import BALL_CENTRE_HEIGHT, MarkerLayout

from ..camera.field_corners import FieldReference
from ..camera.field_view import FieldView, TagFitStats
from ..camera.figure_mask import FigureGeometry
from ..camera.geometry import Lens, PlaneMapping
from ..detection.ball_colour import ColourLearner, ColourVote, MotionColourVote
from ..detection.ball_search import NOTHING, BallSearch, SearchWindow
from ..detection.candidate_rules import (
    ACQUIRE_WINDOW,
    MAX_SPILL,
    confident,
    same_ball_reach,
    solid,
    streak_search_due,
    weak_too_long,
)
from ..detection.detector import (
    BALL_COLOR_NAMES,
    BallDetector,
    Candidate,
    ColourModel,
    colour_model,
    learn_colour,
)
from .velocity import ConstantVelocityKalman, KalmanState

ACQUIRE_SOLID_RATIO = 0.6  # a white ball's shaded side leaves its colour box: 0.7 of the disc is typical
CONFIDENT_RUN = 3  # ball-like frames in a row that make a track on partial blobs healthy again
HEALTHY_FILL, HEALTHY_ROUNDNESS = 0.75, 0.8  # or a single frame this filled and round
ELSEWHERE_EVERY = 3  # frames between searches of the whole field for a whole ball while the track is weak
EDGE_SAMPLES = 40  # whole balls in view whose colour masks give the mask's edge radius (BallDetector.edge_scale)


@dataclass
class TrackerConfig:
    ball_color: Union[str, ColourModel] = "auto"  # a prototype's name, auto, or a colour learned before (choose_colour)
    intrinsics: Optional[Intrinsics] = None
    tag_interval: int = 30  # frames between tag refits once the tags are found (the camera is mounted)
    fovy_hint: float = 50.0  # used only for parallax (tags off the ball plane, or field corners) and no intrinsics
    auto_frames: int = 24  # frames at least used to pick the colour in auto mode
    learn_after: int = 0  # > 0: confident detections before the colour box is re-centred on the ball seen (off:
    # on renders re-centring lost the ball's rim pixels and doubled the median error)
    measurement_std: float = 0.0015
    # foos_core table parameters: the field's and the ball's size, where the rods are; None = nominal
    params_file: Optional[str] = None


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
class TrackerStats(TagFitStats):  # the tag fits' counts (field_view), and the tracker's:
    frames: int = 0
    frames_with_mapping: int = 0
    detections: int = 0
    masked_frames: int = 0  # frames searched with the figure mask (joint positions known)


def search_window(state: KalmanState) -> SearchWindow:
    """Where the detection stage's searches look: the filter's position at state.t and its uncertainty."""
    return SearchWindow(state.t, state.x[:2], state.P[:2, :2])


class BallTracker:
    def __init__(self, layout: FieldReference, config: TrackerConfig | None = None,
                 figures: Optional[FigureGeometry] = None):
        """layout: the markers file's tags, or the field's corners in the image (FieldCorners, a camera that does not
        move); figures: the table's figure boxes; with them, process(..., joints) masks out the figures' pixels."""
        self.layout = layout
        self.figures = figures
        self.config = config or TrackerConfig()
        given = self.config.ball_color
        if not isinstance(given, ColourModel) and given != "auto" and given not in BALL_COLOR_NAMES:
            raise ValueError(f"unknown ball colour `{given}` (auto, {', '.join(BALL_COLOR_NAMES)})")
        self.stats = TrackerStats()
        self.view = FieldView(layout, self.config.params_file, self.config.intrinsics, self.config.fovy_hint,
                              self.stats, figures)
        self.kalman = ConstantVelocityKalman(measurement_std=self.config.measurement_std)
        start = given if isinstance(given, ColourModel) else colour_model("white" if given == "auto" else given)
        self.search = BallSearch(self.view, BallDetector(start))
        self._colour_vote = ColourVote()
        self._motion_colour = MotionColourVote()
        self._colour_settled = self.config.ball_color != "auto"
        self._learner = ColourLearner(self.config.learn_after)
        self._whole_ratios: deque = deque(maxlen=EDGE_SAMPLES)  # area ratios of whole balls in plain view
        self._last_t: Optional[float] = None
        self._weak_since: Optional[float] = None
        self._weak_since_frame = 0
        self._confident_run = 0
        self._misses = 0  # frames since the last detection
        self._weak_frames = 0
        self._pending: Optional[tuple[float, float, float]] = None  # (t, u, v) of an unconfirmed new track

    # --- what the tracker shows -------------------------------------------------------------------
    @property
    def detector(self) -> BallDetector:
        return self.search.detector

    @property
    def colour(self) -> ColourModel:
        return self.search.colour

    @property
    def colour_settled(self) -> bool:
        """The ball's colour is known: given, or `auto` has settled it (no detection before)."""
        return self._colour_settled

    @property
    def mapping(self) -> Optional[PlaneMapping]:
        return self.view.mapping

    @property
    def lens(self) -> Lens:
        return self.view.lens

    @property
    def last_tag_corners(self) -> dict[int, np.ndarray]:
        return self.view.last_tag_corners

    @property
    def last_fit_error(self) -> Optional[str]:
        return self.view.last_fit_error

    @property
    def rod_axes(self) -> Optional[np.ndarray]:
        """uint8 image, 255 on each rod's axis as placed on the steel seen (rods not found left out); None before
        the first tag fit."""
        return self.view.rod_axes

    @property
    def figures_guarded(self) -> bool:
        """A figure of the ball's colour cannot pass for the ball in this frame: the figures are masked out, or
        the ball is coloured and every rod was found on its steel, so a blob over a rod (a figure's head,
        `covers_rod`) is dropped. (A figure's legs and feet are not dropped, but joined to its body over the rod
        they start no track, `starts_track`.)"""
        return self.view.figures_masked or (self.search.rules.rods_tell_figures(self.colour)
                                            and not self.view.rods_unseen)

    def set_figures(self, joints: Optional[np.ndarray]) -> None:
        """Search this frame's field without the figures at these joint positions (16, JOINT_NAMES order);
        None: the whole field, as without joint states."""
        self.view.set_figures(joints)

    def pixel_to_table(self, u: float, v: float) -> np.ndarray:
        return self.view.pixel_to_table(u, v)

    # --- per frame --------------------------------------------------------------------------------
    def process(self, bgr: np.ndarray, t: float, joints: Optional[np.ndarray] = None) -> Optional[Detection]:
        """The ball in this frame, or None (no ball is ever guessed). joints: the 16 rod joint positions at the
        frame's time (JOINT_NAMES order), when known and the tracker has figures: their pixels are not ball."""
        if bgr is None or bgr.ndim != 3 or bgr.shape[2] != 3:
            raise ValueError("the tracker needs 3-channel BGR frames")
        if self._last_t is not None and t < self._last_t:
            raise ValueError(f"frame times go backwards ({t:.6f} s after {self._last_t:.6f} s)")
        self._last_t = t
        self.view.use_frame_size((bgr.shape[1], bgr.shape[0]))
        self.stats.frames += 1
        if self.view.mapping is None or self.stats.frames % self.config.tag_interval == 0:
            self.view.refit(bgr)
        if self.view.mapping is None:
            return None
        self.stats.frames_with_mapping += 1
        self.search.motion.look(bgr, self.view.roi, self.view.region)
        self.view.set_figures(joints)
        self.stats.masked_frames += int(self.view.figures_masked)
        if not self._colour_settled:
            self._vote_colour(bgr)
            if not self._colour_settled:
                return None  # no colour yet: a guess could be a rod or a hand
        chosen, lab_roi, roi = self._find(bgr, t)
        self.search.after_streak = chosen is not None and chosen.streak is not None
        if chosen is not None and chosen.hidden == 0 and solid(chosen, ACQUIRE_SOLID_RATIO):
            self._measure_edge(chosen)
            self.search.note_whole_ball(bgr, chosen)
        if chosen is None:
            self._misses += 1
            return None
        self._misses = 0
        xy = self.view.pixel_to_table(chosen.u, chosen.v)
        self.kalman.update(t, xy, self.search.measurement_covariance(chosen, self.config.measurement_std))
        self.stats.detections += 1
        if self.config.learn_after > 0 and not self._learner.learned and self._colour_settled and confident(chosen):
            self._learn_colour(lab_roi, roi, chosen)
        return Detection(t, float(xy[0]), float(xy[1]), BALL_CENTRE_HEIGHT, chosen.u, chosen.v, chosen.area_ratio)

    def _find(self, bgr: np.ndarray, t: float):
        """The ball near the running track, else a new track's first sighting: (candidate, Lab pixels, roi)."""
        state = self.kalman.predict(t)
        if state is not None:
            predicted, last = search_window(state), search_window(self.kalman.state)
            found = self.search.near(bgr, predicted, t - last.t, self._misses)
            if found[0] is not None and solid(found[0]):
                self._weak_since = None
                self._confident_run = 0
                return found
            # No ball where the track expects one, or only part of one that is not round: a shot's motion-blurred
            # streak, within a shot's reach (a ball that moved its width or more while the shutter was open is not a
            # round blob; a round one half in its colour box, a white ball's shaded side, is not looked past).
            round_ball = found[0] is not None and confident(found[0]) and found[0].roundness >= HEALTHY_ROUNDNESS
            blurred = (self.search.streak(bgr, predicted, last)
                       if not round_ball and streak_search_due(t - last.t, self._misses) else NOTHING)
            if blurred[0] is not None and (found[0] is None or self.search.streak_from(blurred[0], last)):
                self._weak_since = None
                self._confident_run = 0
                return blurred
            if found[0] is not None:
                return self._follow_partial(bgr, t, found)
            # Nothing of the ball's colour box, nor a streak: the ball's colour where the table changed (motion_ball).
            moved = self.search.moved_near(bgr, predicted, t - last.t)
            if moved[0] is not None:
                return self._follow_partial(bgr, t, moved)  # never a whole ball: a track on these alone ends
        return self._acquire(bgr, t)

    def _follow_partial(self, bgr: np.ndarray, t: float, found):
        """Not a whole, round ball where one is expected: a ball behind a rod or a foot, or a figure of the ball's
        colour that the track slid onto when the ball was picked up. A whole ball elsewhere on the field settles
        it (looked for every few frames only: a whole-field search costs as much as tracking)."""
        self._weak_frames += 1
        elsewhere = (self.search.solid_elsewhere(bgr, found[0]) if self._weak_frames % ELSEWHERE_EVERY == 1
                     else NOTHING)
        if elsewhere[0] is not None:
            self.kalman.reset()
            self._weak_since = None
            self._confident_run = 0
            return elsewhere
        # A figure's outline passes for a ball now and then, a ball in view does so frame after
        # frame: only a run of ball-like frames makes a track healthy again.
        # A ball merged with something of its colour is no proof either: the end of a red figure's
        # bar is a ball-sized, roundish blob that goes on past the ball's outline.
        ball_like = confident(found[0]) and found[0].spill <= MAX_SPILL
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
        if not weak_too_long(t - self._weak_since, self.stats.frames - self._weak_since_frame, self.figures_guarded):
            return found
        return NOTHING

    def _acquire(self, bgr: np.ndarray, t: float):
        """A new track: a whole ball, or a ball-like blob or a short streak seen twice running, or a run of partial
        balls."""
        found = self.search.on_field(bgr, t)
        if found[0] is None:
            run = self.search.partial_run(self.figures_guarded)
            if run[0] is not None:
                self._pending = None
                self.search.forget_partials()
                self._weak_since = None
                self._confident_run = 0
                return run
            # A ball rolling or flying a little too fast for its colour box to take it whole: a short streak, which
            # like a ball-like blob needs a second sighting (either) to start a track.
            found = self.search.short_streak(bgr)
            if found[0] is None:
                self._pending = None
                return run
        # A new track needs a ball-like blob in two frames running, close together: the outline of a
        # figure of a similar colour passes for a ball in a single frame now and then, a ball in view
        # does so frame after frame.
        c, pending = found[0], self._pending
        self._pending = (t, c.u, c.v)
        if solid(c, ACQUIRE_SOLID_RATIO):
            pending = (t, c.u, c.v)  # a whole, round, filled disc on its own needs no second look
        elif pending is None or t - pending[0] > ACQUIRE_WINDOW:
            return NOTHING
        if math.hypot(c.u - pending[1], c.v - pending[2]) > same_ball_reach(self.view, c.u, c.v, t - pending[0]):
            return NOTHING
        self._pending = None
        self._weak_since = None
        self._confident_run = 0
        return found

    # --- colour -------------------------------------------------------------------------------------
    def _vote_colour(self, bgr: np.ndarray) -> None:
        leading, settled = self._colour_vote.vote(bgr, self.view,
                                                  self.stats.frames_with_mapping >= self.config.auto_frames)
        if leading is not None:
            self.search.detector = BallDetector(colour_model(leading))
        if not settled:
            # No prototype fits (a yellow-green ball, a cork one): the colour of what moves like a ball, once clear.
            self._motion_colour.add(self.search.motion.moved(self.view.radius_at_pixel), self.view)
            learned = (self._motion_colour.model(self.search.felt_colour(bgr))
                       if self.stats.frames_with_mapping >= 2 * self.config.auto_frames else None)
            if learned is not None:
                self.search.detector = BallDetector(learned)
                settled = True
        if settled:
            self._colour_settled = True
            self.kalman.reset()

    def _measure_edge(self, whole: Candidate) -> None:
        """How much of a whole ball the colour mask takes (BallDetector.edge_scale), from the balls seen whole."""
        self._whole_ratios.append(whole.area_ratio)
        if len(self._whole_ratios) >= EDGE_SAMPLES // 2:
            self.search.detector.edge_scale = float(np.clip(math.sqrt(np.median(self._whole_ratios)), 0.7, 1.0))

    def _learn_colour(self, lab: np.ndarray, roi, c: Candidate) -> None:
        pixels = self._learner.collect(lab, roi, c, self.view.radius_at_pixel(c.u, c.v))
        if pixels is not None:
            detector = self.search.detector
            self.search.detector = BallDetector(learn_colour(detector.model, pixels), detector.edge_scale)


def choose_colour(frames, layout: MarkerLayout, config: TrackerConfig | None = None, fps: float = 30.0,
                  figures: Optional[FigureGeometry] = None, joints_at=None) -> Union[str, ColourModel, None]:
    """The ball colour `auto` settles on over these frames (None when it cannot tell): a prototype's name, or the
    colour learned from the moving ball (a ColourModel), so an offline run can track its first frames with it too.
    joints_at(t): the rod joints at a frame's time
    (or None), to leave the figures out of the vote."""
    config = config or TrackerConfig()
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto", intrinsics=config.intrinsics,
                                                tag_interval=config.tag_interval, fovy_hint=config.fovy_hint,
                                                auto_frames=config.auto_frames, params_file=config.params_file),
                          figures)
    for k, frame in enumerate(frames):
        tracker.process(frame, k / fps, joints_at(k / fps) if joints_at is not None else None)
        if tracker.colour_settled:
            return tracker.colour.name if tracker.colour.name in BALL_COLOR_NAMES else tracker.colour
    return None
