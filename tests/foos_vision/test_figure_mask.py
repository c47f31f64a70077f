"""The figure mask from /joint_states: figure boxes posed by the rod joints, projected with the camera the
tags give, and kept out of the ball search (red ball among red figures)."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_bag import BagWriter, write_ball_detections, write_joint_states
from foos_core.camera_model import load_camera
from foos_core.names import JOINT_NAMES
from foos_sim.camera.render import read_joints
from foos_vision.camera.figure_mask import FigureGeometry, JointTrack, joint_track, projection_from_mapping
from foos_vision.camera.geometry import PlaneMapping
from foos_vision.tracking.tracker import BallTracker, TrackerConfig

from . import drawn_table as dt
from .helpers import ros2_run

RED_BGR = (30, 30, 215)
ROD_Y, SPACING = 0.225, 0.185  # home attack, 3 figures (foos_sim's regulation table)
FOOT_X, FOOT_Y = 0.030, 0.022


@pytest.fixture(scope="module")
def geometry():
    return FigureGeometry()


def joints(slide: float = 0.0, rotate: float = 0.0) -> np.ndarray:
    q = np.zeros(len(JOINT_NAMES))
    q[JOINT_NAMES.index("home_attack_slide")] = slide
    q[JOINT_NAMES.index("home_attack_rotate")] = rotate
    return q


def test_figure_boxes_follow_the_rod_joints(geometry):
    names = [geometry.model.geom(int(g)).name for g in geometry.geoms]
    feet = [i for i, n in enumerate(names) if n.startswith("home_attack_figure") and n.endswith("_foot")]
    assert len(feet) == 3 and len(names) == 44  # 22 figures, a body and a foot each
    rest = geometry.corners(joints()).mean(axis=1)[feet]
    assert np.allclose(sorted(rest[:, 0]), [-SPACING, 0.0, SPACING], atol=1e-6)
    assert np.allclose(rest[:, 1], ROD_Y, atol=1e-6) and np.all(rest[:, 2] < 0.03)
    slid = geometry.corners(joints(slide=0.05)).mean(axis=1)[feet]
    assert np.allclose(slid[:, 0] - rest[:, 0], 0.05, atol=1e-6)
    kicked = geometry.corners(joints(rotate=0.5)).mean(axis=1)[feet]
    assert np.all(kicked[:, 1] > ROD_Y + 0.02)  # + rotate swings the foot toward +y (contract)


@pytest.mark.parametrize("camera", ["overhead", "oblique"])
def test_projection_from_the_tag_homography_matches_the_camera(camera, geometry):
    cam = load_camera(camera).with_(width=640, height=480)
    plane = np.array([[-0.4, -0.6], [0.4, -0.6], [0.4, 0.6], [-0.4, 0.6], [0.1, 0.2]])
    pixels = cam.project(np.c_[plane, np.full(len(plane), 0.0175)], distorted=False)
    h, _ = cv2.findHomography(plane, pixels)
    mapping = PlaneMapping(np.linalg.inv(h), h, 0.0, len(plane), math.nan)
    corners = geometry.corners(joints(slide=0.1, rotate=0.7)).reshape(-1, 3)
    truth = cam.project(corners, distorted=False)
    # With the intrinsics the projection is exact; without, the focal length comes from the homography
    # (oblique) or the 50 degree hint (overhead camera: its true fovy differs): within the mask's 2 px margin.
    for k, tolerance in ((cam.camera_matrix(), 0.01), (None, 1.5)):
        p = projection_from_mapping(mapping, (640, 480), k) @ np.c_[corners, np.ones(len(corners))].T
        assert np.abs(p[:2].T / p[2:].T - truth).max() < tolerance


def test_joint_track_interpolates_and_refuses_incomplete_states():
    track = JointTrack(np.array([0.0, 0.01, 0.5]), np.array([[0.0] * 16, [1.0] * 16, [2.0] * 16]))
    assert np.allclose(track.at(0.005), 0.5) and track.at(0.2) is None and track.at(0.52) is not None
    assert track.at(0.6) is None
    with pytest.raises(Exception, match="lack"):
        joint_track(np.zeros(2), list(JOINT_NAMES[:15]), np.zeros((2, 15)), "bag")
    with pytest.raises(Exception, match="finite"):
        joint_track(np.zeros(1), list(JOINT_NAMES), np.full((1, 16), np.nan), "bag")


def drawn_rod(frame: np.ndarray, slide: float) -> None:
    """The three home attack figures hanging down, seen from above: red foot blocks at the rod's y."""
    for i in (-1, 0, 1):
        x = slide + i * SPACING
        u0, v0 = dt.to_pixel(x - FOOT_X / 2, ROD_Y - FOOT_Y / 2)
        u1, v1 = dt.to_pixel(x + FOOT_X / 2, ROD_Y + FOOT_Y / 2)
        cv2.rectangle(frame, (int(round(u0)), int(round(v0))), (int(round(u1)), int(round(v1))), RED_BGR, -1)


def track_drawn(layout, geometry, masked: bool, ball_path):
    tracker = BallTracker(layout, TrackerConfig(ball_color="red"), geometry if masked else None)
    found = {}
    for k in range(len(ball_path)):
        t = k / dt.FPS
        slide = 0.06 * math.sin(2 * math.pi * 1.5 * t)
        frame = dt.table_frame()
        drawn_rod(frame, slide)
        if ball_path[k] is not None:
            dt.draw_ball(frame, *ball_path[k], bgr=RED_BGR)
        d = tracker.process(frame, t, joints(slide) if masked else None)
        if d is not None:
            found[k] = (d.x, d.y)
    return found, tracker


@pytest.mark.timeout(60)
def test_red_figures_are_no_ball_with_the_mask(tmp_path, geometry):
    layout = dt.write_layout(tmp_path / "markers.yaml")
    # The ball picked up: only the sliding red figures are in view.
    empty = [None] * 90
    without, _ = track_drawn(layout, geometry, False, empty)
    assert len(without) >= 10, "the drawn figures should pass for a red ball without the mask"
    masked, tracker = track_drawn(layout, geometry, True, empty)
    assert masked == {} and tracker.stats.masked_frames == 90
    # A red ball rolling past the figures, touching them: found and centred by its part outside them.
    path = [(-0.30 + 0.6 * k / 89, ROD_Y - (FOOT_Y / 2 + 0.0175 + 0.001)) for k in range(90)]
    masked, _ = track_drawn(layout, geometry, True, path)
    assert len(masked) >= 85
    errors = [math.hypot(x - path[k][0], y - path[k][1]) for k, (x, y) in masked.items()]
    assert np.median(errors) < 0.002 and max(errors) < 0.006


def rod_bag(video, path, with_joints: bool = True):
    t, names, position = read_joints(video.with_suffix("").as_posix() + ".joints.csv")
    with BagWriter(path) as bag:
        if with_joints:
            write_joint_states(bag, t, names, position, np.zeros_like(position))
        else:
            write_ball_detections(bag, t[:3], np.zeros((3, 3)))
    return path


@pytest.mark.timeout(120)
def test_track_video_takes_joint_states_and_refuses_a_bag_without_them(overhead_video, tmp_path):
    markers = overhead_video.with_suffix("").as_posix() + ".markers.yaml"
    no_joints = rod_bag(overhead_video, tmp_path / "no_joints", with_joints=False)
    result = ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(tmp_path / "bag"),
                      "--joint-states", str(no_joints), "--quiet")
    assert result.returncode == 2 and "no /joint_states" in result.stderr, result.stderr
    assert len(result.stderr.strip().splitlines()) == 1 and "Traceback" not in result.stderr
    assert not (tmp_path / "bag").exists()
    missing = ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(tmp_path / "bag"),
                       "--joint-states", str(tmp_path / "nope"), "--quiet")
    assert missing.returncode == 2 and len(missing.stderr.strip().splitlines()) == 1, missing.stderr
    rods = rod_bag(overhead_video, tmp_path / "rods")
    result = ros2_run("track_video", str(overhead_video), "--markers", markers, "--out", str(tmp_path / "bag"),
                      "--joint-states", str(rods), "--quiet")
    assert result.returncode == 0, result.stderr
    assert "figure mask in 73 frames" in result.stdout, result.stdout


def test_a_straight_down_view_with_tag_noise_falls_back_on_the_hint(geometry):
    # Tag centres found to a few tenths of a pixel tilt the homography of a straight-down view a little: the
    # focal length it then reveals can be any size (200 000 px on a 1.9 m overhead render, a camera hundreds
    # of metres up, no parallax at all: the far rods' figures masked 5 px off). Such a value is refused.
    cam = load_camera("overhead").with_(width=640, height=480)
    plane = np.array([[-0.6, -0.7], [0.6, -0.7], [0.6, 0.0], [-0.6, 0.0], [0.6, 0.7], [-0.6, 0.7]])
    pixels = cam.project(np.c_[plane, np.full(len(plane), 0.0175)], distorted=False)
    corners = geometry.corners(joints(slide=0.1)).reshape(-1, 3)
    truth = cam.project(corners, distorted=False)
    rng = np.random.default_rng(3)
    for _ in range(20):
        h, _ = cv2.findHomography(plane, pixels + rng.normal(0.0, 0.3, pixels.shape))
        mapping = PlaneMapping(np.linalg.inv(h), h, 0.0, len(plane), math.nan)
        p = projection_from_mapping(mapping, (640, 480), None) @ np.c_[corners, np.ones(len(corners))].T
        assert np.abs(p[:2].T / p[2:].T - truth).max() < 2.0
