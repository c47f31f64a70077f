"""A ball half under a steel rod (drawn frames, real ArUco tags, real OpenCV): the rod is always in front of the
ball (its underside is 70 mm up, the ball's top 35 mm), so where its image crosses the ball's disc, the ball is
hidden, not missing. The tracker draws the rods' image from the tags' camera and judges a partial blob against
what the rod leaves in view: a cap above a rod fills the part of the disc in view and is as round as such a cap
can be, while the inner disc that `fill` looks at and the roundness of a whole disc are mostly behind the rod.

The oblique 640x480 orange bench case lost its ball this way, at rest half under the goalie rod (v61, v81) and
under the far defence rod (s31)."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_core.markers import MarkerLayout
from foos_core.names import JOINT_NAMES
from foos_vision.camera.figure_mask import FigureGeometry, projection_from_mapping
from foos_vision.camera.rod_lines import rod_geometry, rod_mask
from foos_vision.detection.ball_search import PARTIAL_RUN
from foos_vision.tracking.tracker import BallTracker, TrackerConfig

from . import drawn_table
from .drawn_table import ORANGE_BGR, STEEL_BGR

# A small drawn table seen straight from above: a ball of 4.5 px radius, as at the far end of the oblique 640x480
# view (a ball of 5 px or more is first looked for at half resolution).
SCALE = 260.0  # px per m: u = 319.5 + SCALE * y, v = 239.5 + SCALE * x
TAG_PX = 24  # 4 px per cell of a 4x4 tag with its border
RADIUS_PX = 0.0175 * SCALE
ROD_Y = 0.225  # home attack: figures at x = -0.185, 0, 0.185 when centred, none near the ball
BALL_X = 0.09


def to_pixel(x: float, y: float) -> tuple[float, float]:
    return drawn_table.to_pixel(x, y, SCALE)


@pytest.fixture(scope="module")
def layout(tmp_path_factory) -> MarkerLayout:
    return drawn_table.write_layout(tmp_path_factory.mktemp("rod") / "markers.yaml", TAG_PX / SCALE)


def table_frame() -> np.ndarray:
    return drawn_table.table_frame(SCALE, TAG_PX, border=4)


def rods_in_view(tracker: BallTracker) -> np.ndarray:
    """Where the tracker's camera (from the tags; the drawn view is straight down) sees the steel rods."""
    projection = projection_from_mapping(tracker.mapping, (640, 480), None, tracker.config.fovy_hint)
    return rod_mask(rod_geometry(), projection, tracker.lens.distort, (640, 480)) > 0


def resting_under_the_rod(layout, hidden_share: float, ring: bool = False, masked: bool = True) -> tuple[dict, float]:
    """At 60 fps, a ball at rest beside the rod at y = ROD_Y with `hidden_share` of its disc behind it, never seen
    whole, while no track runs (or, ring: the hollow outline of a figure of the ball's colour there). Returns the
    detections by frame, and the ball's y."""
    probe = BallTracker(layout, TrackerConfig(ball_color="orange"))
    probe.process(table_frame(), 0.0)  # the tags: the camera and so the rods' image
    rods = rods_in_view(probe)
    tracker = BallTracker(layout, TrackerConfig(ball_color="orange"), FigureGeometry())
    hanging = np.zeros(len(JOINT_NAMES))
    empty = table_frame()
    empty[rods] = STEEL_BGR
    tracker.process(cv2.GaussianBlur(empty, (3, 3), 0.7), 0.0)  # the table with its rods, before the ball
    u_rod, v_ball = to_pixel(BALL_X, ROD_Y)
    columns = np.nonzero(rods[int(round(v_ball))])[0]
    edge = columns[np.abs(columns - u_rod) < 20].min() - 0.5  # the rod's image begins here (it runs along v)
    radius = RADIUS_PX
    # The rod hides the part of the disc beyond a chord at distance d from the centre: find d for the share.
    distances = np.linspace(-radius + 0.01, radius - 0.01, 2000)
    segment = (np.arccos(distances / radius) - distances * np.sqrt(radius**2 - distances**2) / radius**2) / math.pi
    d = float(distances[np.argmin(np.abs(segment - hidden_share))])
    y = (edge - d - 319.5) / SCALE
    found = {}
    for k in range(1, 16):
        frame = table_frame()
        drawn_table.draw_ball(frame, BALL_X, y, ORANGE_BGR, SCALE, thickness=1 if ring else -1)
        frame[rods] = STEEL_BGR
        detection = tracker.process(cv2.GaussianBlur(frame, (3, 3), 0.7), k / 60.0, hanging if masked else None)
        if detection is not None:
            found[k] = (detection.x, detection.y)
    return found, y


@pytest.mark.timeout(60)
@pytest.mark.parametrize("hidden_share, masked", [(0.55, True), (0.65, True), (0.45, False)])
def test_a_ball_resting_half_under_a_rod_starts_a_track(layout, hidden_share, masked):
    found, y = resting_under_the_rod(layout, hidden_share, masked=masked)
    # Never whole, so a run of partial blobs on one steady path (at rest) starts the track: with the figures masked,
    # and without the mask too, since for a coloured ball a figure's head over its rod is dropped. Without the mask
    # what shows is judged against the whole disc (the rods' share counts only with it: without, red figures half
    # behind their rods passed for balls), so there the ball may be no more than about half hidden.
    assert found and min(found) <= PARTIAL_RUN, sorted(found)
    assert all(k in found for k in range(min(found), 16)), sorted(found)
    for k, (dx, dy) in found.items():
        assert math.hypot(dx - BALL_X, dy - y) < 0.004, (k, dx, dy, y)


@pytest.mark.timeout(60)
@pytest.mark.parametrize("masked", [True, False])
def test_no_track_under_a_rod_from_a_hollow_outline(layout, masked):
    ring, _ = resting_under_the_rod(layout, 0.45, ring=True, masked=masked)
    assert not ring, sorted(ring)
