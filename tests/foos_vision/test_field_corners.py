"""track_video --field-corners as a user runs it: renders of the regulation table and of a 1.187 x 0.673 m one,
corners given to 2 px, the track against the render's truth; bad corners are one-line errors; the corner
geometry itself (no video)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest
import yaml

from foos_bag import read_ball_detections
from foos_core.camera_model import CameraConfig, load_camera
from foos_core.markers import BALL_CENTRE_HEIGHT
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.camera.render import read_truth
from foos_vision.camera.corner_refine import refine_field_corners
from foos_vision.camera.field_corners import FieldCornersError, parse_field_corners
from foos_vision.camera.geometry import Lens, corner_camera_matrix, corner_focal, fit_field_corners
from foos_vision.camera.rod_lines import rod_geometry

from .helpers import render, ros2_run
from .test_track_video import one_line_error

SMALL_TABLE = "base: regulation_table\nfield: {width: 0.673, length: 1.187}\n"
CLICK_ERROR_PX = 2.0


@pytest.fixture(scope="module")
def small_table(tmp_path_factory):
    path = tmp_path_factory.mktemp("table") / "small_table.yaml"
    path.write_text(SMALL_TABLE)
    return path


@pytest.fixture(scope="module")
def videos(overhead_video, small_table, tmp_path_factory):
    """(video, params file or None) per (table, camera); the regulation overhead one is conftest's."""
    folder = tmp_path_factory.mktemp("corners")
    made = {("regulation", "overhead"): (overhead_video, None)}
    for table, params in (("regulation", None), ("small", small_table)):
        for camera in ("overhead", "oblique"):
            if (table, camera) in made:
                continue
            extra = ["--params-file", str(params)] if params else []
            video = render(folder / f"{table}_{camera}.mp4", "--camera", camera, "--fps", "60", "--duration", "1.2",
                           "--ball-color", "yellow", "--hide-every", "0.6", "--hide-for", "0.3", "--visibility",
                           "--seed", "3", *extra)
            made[(table, camera)] = (video, params)
    return made


def rendered_camera(video) -> CameraConfig:
    """The camera render_video used, from OUT.camera.yaml (its `intrinsics:` block is for the tracker)."""
    tree = yaml.safe_load(open(video.with_suffix("").as_posix() + ".camera.yaml"))
    tree.pop("intrinsics")
    return CameraConfig(**{key: tuple(v) if isinstance(v, list) else v for key, v in tree.items()})


def field_corner_pixels(camera: CameraConfig, table: TableGeometry) -> np.ndarray:
    """Where the camera sees the surface's corners at (-x,-y), (+x,-y), (+x,+y), (-x,+y) (through its lens)."""
    x, y = table.half_width, table.half_length
    return camera.project(np.array([(-x, -y, 0.0), (x, -y, 0.0), (x, y, 0.0), (-x, y, 0.0)]))


def clicked(pixels: np.ndarray, seed: int) -> str:
    """The corners as a user gives them: each CLICK_ERROR_PX off in a seeded direction, to 0.1 px."""
    angle = np.random.default_rng(seed).uniform(0, 2 * np.pi, 4)
    off = pixels + CLICK_ERROR_PX * np.column_stack([np.cos(angle), np.sin(angle)])
    return ",".join(f"{v:.1f}" for v in off.ravel())


def track_errors(video, bag):
    """(errors in m, detected frame indices, frames at least half visible, detections while picked up)."""
    truth = read_truth(video.with_suffix("").as_posix() + ".truth.csv")
    detections = read_ball_detections(bag)
    frames = np.round(detections.t * 60).astype(int)
    error = np.hypot(detections.position[:, 0] - truth["x"][frames], detections.position[:, 1] - truth["y"][frames])
    half_visible = np.nonzero(truth["visible"] >= 0.5)[0]
    return error, frames, half_visible, int(np.isnan(truth["x"][frames]).sum())


@pytest.mark.timeout(300)
@pytest.mark.parametrize("table", ["regulation", "small"])
@pytest.mark.parametrize("camera", ["overhead", "oblique"])
def test_corners_given_to_2_px_track_to_3_mm(videos, table, camera, tmp_path):
    video, params = videos[(table, camera)]
    geometry = TableGeometry.of(params)
    truth_corners = field_corner_pixels(rendered_camera(video), geometry)
    for seed in (1, 2):
        bag = tmp_path / f"bag{seed}"
        extra = ["--params-file", str(params)] if params else []
        result = ros2_run("track_video", str(video), "--field-corners", clicked(truth_corners, seed), "--out", str(bag),
                          "--quiet", *extra)
        assert result.returncode == 0, result.stderr
        assert "field corners fitted to" in result.stdout, result.stdout
        error, frames, half_visible, while_picked_up = track_errors(video, bag)
        assert while_picked_up == 0
        assert np.median(error) <= 0.003, (table, camera, seed, np.median(error))
        assert np.percentile(error, 95) <= 0.008, (table, camera, seed, np.percentile(error, 95))
        assert np.isin(half_visible, frames).mean() >= 0.85


@pytest.mark.parametrize(("table", "camera"), [("regulation", "overhead"), ("small", "overhead"),
                                             ("regulation", "oblique"), ("small", "oblique")])
def test_clicked_corners_are_fitted_to_the_tables_edges(videos, table, camera):
    """2 px clicks become corners a fraction of a pixel from the truth: overhead from the felt's edges along all
    four walls and the walls' top edges; from behind the home goal the near surface edge is behind the wall and
    the far one under the goalie rod, and the walls' top edges place the ends."""
    video, params = videos[(table, camera)]
    geometry = TableGeometry.of(params)
    truth = field_corner_pixels(rendered_camera(video), geometry)
    frame = cv2.VideoCapture(str(video)).read()[1]
    walls = load_params(params)["field"]
    for seed in range(4):
        given = np.array(clicked(truth, seed).split(","), float).reshape(4, 2)
        size = (frame.shape[1], frame.shape[0])
        focal = corner_camera_matrix(given, geometry.half_width, geometry.half_length, size)
        revealed = corner_focal(given, geometry.half_width, geometry.half_length, size) is not None
        assert revealed == (camera == "oblique")  # straight down, four corners cannot tell the focal length
        fitted = refine_field_corners(frame, given, Lens(None), focal, revealed, rod_geometry(params),
                                      geometry.half_width, geometry.half_length, geometry.goal_half_width,
                                      walls["wall_height"], walls["wall_thickness"])
        assert fitted.edges_used >= (8 if camera == "overhead" else 5), fitted
        miss = np.linalg.norm(fitted.pixels - truth, axis=1)
        assert np.max(miss) < 0.8 and np.mean(miss) < 0.5, (seed, miss)


def test_no_edge_near_the_corners_leaves_them_as_given():
    camera = load_camera("overhead")
    geometry = TableGeometry.nominal()
    given = field_corner_pixels(camera, geometry)
    bare = np.random.default_rng(0).normal(90, 1.5, (camera.height, camera.width, 3)).clip(0, 255).astype(np.uint8)
    focal = corner_camera_matrix(given, geometry.half_width, geometry.half_length, (camera.width, camera.height))
    fitted = refine_field_corners(bare, given, Lens(None), focal, False, rod_geometry(), geometry.half_width,
                                  geometry.half_length, geometry.goal_half_width, 0.16, 0.03)
    assert fitted.edges_used == 0 and np.array_equal(fitted.pixels, given)


def refused(result, *words):
    """Bad input: exit status 2 and one line that says what is wrong."""
    assert result.returncode == 2, (result.returncode, result.stderr)
    one_line_error(result, *words)


@pytest.mark.timeout(180)
def test_bad_field_corners_are_one_line_errors_and_leave_no_bag(overhead_video, tmp_path):
    markers = overhead_video.with_suffix("").as_posix() + ".markers.yaml"
    good = field_corner_pixels(rendered_camera(overhead_video), TableGeometry.nominal())

    def text(pixels) -> str:
        return ",".join(f"{v:.1f}" for v in np.asarray(pixels).ravel())

    bag = tmp_path / "bag"
    cases = [
        (good.ravel()[:7], ["8 numbers", "got 7"]),
        (np.append(good.ravel(), 5.0), ["8 numbers", "got 9"]),
        (good[[0, 2, 1, 3]], ["convex"]),  # out of order: the sides cross
        (np.vstack([good[:3], [good[:3].mean(axis=0)]]), ["convex"]),  # a corner pointing inward
        (good[::-1], ["clockwise", "order"]),  # the field's mirror image
        (np.vstack([good[:2], [(good[1] + good[3]) / 2 + (1e-3, 0)], good[3:]]), ["line"]),  # three on one line
        (good + (200, 0), ["outside", "640x480"]),
        (good - (0, 140), ["outside", "640x480"]),
    ]
    for corners, words in cases:
        result = ros2_run("track_video", str(overhead_video), "--field-corners", text(corners), "--out", str(bag),
                          "--quiet")
        refused(result, "--field-corners", *words)
        assert not bag.exists()
    refused(ros2_run("track_video", str(overhead_video), "--field-corners", "a,b,c,d,e,f,g,h", "--out", str(bag)),
            "--field-corners", "not a comma-separated list")
    refused(ros2_run("track_video", str(overhead_video), "--markers", markers, "--field-corners", text(good),
                     "--out", str(bag)), "exactly one of --markers", "not both")
    refused(ros2_run("track_video", str(overhead_video), "--out", str(bag)), "exactly one of --markers", "not neither")
    assert not bag.exists()


def test_help_tells_how_to_give_the_corners():
    result = ros2_run("track_video", "--help")
    assert result.returncode == 0
    for words in ("--field-corners", "(-x,-y), (+x,-y), (+x,+y), (-x,+y)", "--params-file", "counter-clockwise"):
        assert words in result.stdout, words


# --- the geometry, without video ------------------------------------------------------------------------


BALLS = np.array([[0.0, 0.0], [0.3, 0.55], [-0.32, -0.58], [0.2, -0.3]])


@pytest.mark.parametrize("camera_name", ["overhead", "oblique"])
def test_exact_corners_map_to_the_ball_plane(camera_name):
    """Four surface corners, lifted to the ball plane by the camera they imply: the oblique view reveals its focal
    length, the straight-down one leaves it to the field-of-view hint (here 5 degrees off)."""
    camera = load_camera(camera_name)
    geometry = TableGeometry.nominal()
    corners = field_corner_pixels(camera, geometry)
    size = (camera.width, camera.height)
    mapping = fit_field_corners(corners, geometry.half_width, geometry.half_length, BALL_CENTRE_HEIGHT, size,
                                fovy_hint=camera.fovy + 5)
    balls = np.c_[BALLS, np.full(len(BALLS), BALL_CENTRE_HEIGHT)]
    recovered = mapping.to_table(camera.project(balls))
    assert np.max(np.linalg.norm(recovered - BALLS, axis=1)) < (1e-4 if camera_name == "oblique" else 1.5e-3)
    # Without the lift, a ball near the far end would be off by its parallax, over a centimetre.
    flat = fit_field_corners(corners, geometry.half_width, geometry.half_length, 0.0, size)
    assert np.max(np.linalg.norm(flat.to_table(camera.project(balls)) - BALLS, axis=1)) > 5e-3
    focal = corner_camera_matrix(corners, geometry.half_width, geometry.half_length, size, fovy_hint=camera.fovy + 5)
    if camera_name == "oblique":
        assert abs(focal[0, 0] - camera.camera_matrix()[0, 0]) < 0.01 * camera.camera_matrix()[0, 0]
    else:  # straight down: the hint's focal length, not a value the corners' last digits make up
        assert abs(focal[0, 0] - (camera.height / 2) / np.tan(np.radians(camera.fovy + 5) / 2)) < 1e-6


def test_corner_text_and_lists_parse_alike():
    text = parse_field_corners(" 136.5, 135.8,136.5,343.2, 502.5,343.2,502.5,135.8 ")
    listed = parse_field_corners([136.5, 135.8, 136.5, 343.2, 502.5, 343.2, 502.5, 135.8])
    assert np.array_equal(text.pixels, listed.pixels) and text.pixels.shape == (4, 2)
    with pytest.raises(FieldCornersError, match="8 numbers"):
        parse_field_corners([1, 2, 3])
    with pytest.raises(FieldCornersError, match="finite"):
        parse_field_corners("1,2,3,4,5,6,7,nan")
    with pytest.raises(FieldCornersError, match="px apart"):
        parse_field_corners("100,100,103,100,300,300,100,300")
