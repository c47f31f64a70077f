"""Offline tracking: the forward tracker plus a backward pass over the frames just before each new track.

A ball that comes out from under a rod or a foot while no track is running is only half visible for a
few frames, and a new track needs a whole ball (or two sightings) to start, so those frames are lost
online. Offline, the frames are still at hand: once a new track has a few detections, and so a
velocity, the same gated search for a partly hidden ball runs backward in time from its first
detection, as if the ball were rolling back. tracker_node cannot do this: it has published by then.
"""
from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass
from typing import Optional

import numpy as np

from foos_core.markers import BALL_CENTRE_HEIGHT

from ..detection.candidate_rules import MAX_SPILL, MIN_PARTIAL_FILL, confident, solid, weak_too_long
from .tracker import BallTracker, Detection, search_window
from .velocity import ConstantVelocityKalman

SEED_DETECTIONS = 3  # detections of a new track that give the backward search its velocity


@dataclass
class TrackedFrame:
    index: int
    detection: Detection
    state: np.ndarray  # Kalman [x, y, vx, vy] at the frame (the backward filter's, turned forward, when backfilled)
    backfilled: bool = False


class OfflineTracker:
    """Feeds frames to a BallTracker and keeps the last frames, to search them again backward when a new
    track starts. Results are keyed by frame index; `results()` gives them in frame order."""

    def __init__(self, tracker: BallTracker, fps: float, backward: bool = True):
        self.tracker = tracker
        self.backward = backward
        # As far back as a track may coast without a detection (the Kalman filter's own limit).
        keep = int(math.ceil(tracker.kalman.max_gap * max(fps, 1.0))) + SEED_DETECTIONS + 2
        self._frames: deque = deque(maxlen=keep)
        self._found: dict[int, TrackedFrame] = {}
        self._track_start: Optional[int] = None  # first frame of a new track whose backward pass is pending
        self.backfilled = 0

    def process(self, index: int, t: float, frame: np.ndarray, joints: Optional[np.ndarray] = None) -> Optional[Detection]:
        """The forward tracker's detection in this frame (what tracker_node would publish). joints: the rod
        joint positions at t, for the figure mask (None: no mask)."""
        detection = self.tracker.process(frame, t, joints)
        if self.backward:
            self._frames.append((index, t, frame, joints))
        if detection is not None:
            self._found[index] = TrackedFrame(index, detection, self.tracker.kalman.state.x.copy())
            if index - 1 not in self._found:
                self._track_start = index
        if self._track_start is not None:
            seeds = self._seeds(self._track_start)
            # Enough of the track for a velocity, or the track is over: search before its start.
            if len(seeds) >= SEED_DETECTIONS or detection is None:
                self._search_back(self._track_start, seeds)
                self._track_start = None
        return detection

    def finish(self) -> None:
        if self._track_start is not None:
            self._search_back(self._track_start, self._seeds(self._track_start))
            self._track_start = None

    def results(self) -> list[TrackedFrame]:
        return [self._found[k] for k in sorted(self._found)]

    def _seeds(self, start: int) -> list[TrackedFrame]:
        seeds = []
        for k in range(start, start + 4 * SEED_DETECTIONS):
            if k in self._found:
                seeds.append(self._found[k])
                if len(seeds) == SEED_DETECTIONS:
                    break
        return seeds

    def _search_back(self, start: int, seeds: list[TrackedFrame]) -> None:
        if not self.backward or not seeds or self.tracker.mapping is None:
            return
        tr = self.tracker
        # Time runs backward: a filter fed -t sees the ball roll back along its path at the same speed.
        kalman = ConstantVelocityKalman(measurement_std=tr.config.measurement_std)
        for seed in reversed(seeds):
            kalman.update(-seed.detection.t, np.array([seed.detection.x, seed.detection.y]))
        try:
            self._search_frames_back(start, kalman)
        finally:
            # The forward tracker goes on with the newest frame's figures.
            tr.set_figures(self._frames[-1][3] if self._frames else None)

    def _search_frames_back(self, start: int, kalman: ConstantVelocityKalman) -> None:
        tr = self.tracker
        weak_since = None  # (t, index) of the latest frame of the current run of partial blobs
        for index, t, frame, joints in reversed(self._frames):
            if index >= start:
                continue
            if index in self._found:
                break  # back at the previous track
            state = kalman.predict(-t)
            if state is None:
                break  # longer than a track may coast
            # Frame by frame from a seen ball: no allowance for a hit while hidden, and the pass ends at the
            # first frame without the ball. Before a gap the ball's path is unknown (the serve, a kick), and a
            # figure of its colour there would pass for a half-hidden ball.
            tr.set_figures(joints)
            candidate, _, _ = tr.search.near(frame, search_window(state), 0.0, 0)
            if candidate is None or not solid(candidate):
                # A shot's streak, as the forward tracker finds one (the filter's previous state is a later frame's).
                candidate = tr.search.streak(frame, search_window(state), search_window(kalman.state))[0] or candidate
            # Hollow (a figure's outline) or merged with something of its colour (its centre pulled off): not
            # a ball to start a track's history with.
            if candidate is None or candidate.fill < MIN_PARTIAL_FILL or candidate.spill > MAX_SPILL:
                break
            if not (solid(candidate) or confident(candidate) or candidate.streak is not None):
                # Parts of a ball alone, for no longer than the forward tracker allows them.
                weak_since = (t, index) if weak_since is None else weak_since
                if weak_too_long(weak_since[0] - t, weak_since[1] - index, tr.figures_guarded):
                    break
            else:
                weak_since = None
            xy = tr.pixel_to_table(candidate.u, candidate.v)
            kalman.update(-t, xy, tr.search.measurement_covariance(candidate, tr.config.measurement_std))
            forward = kalman.state.x * np.array([1.0, 1.0, -1.0, -1.0])
            detection = Detection(t, float(xy[0]), float(xy[1]), BALL_CENTRE_HEIGHT, candidate.u, candidate.v,
                                  candidate.area_ratio)
            self._found[index] = TrackedFrame(index, detection, forward, backfilled=True)
            self.backfilled += 1
