"""Tag geometry, parallax correction, markers and camera files, and the velocity estimators (no video)."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_core.camera_model import FISHEYE_RENDER_SCALE, CameraConfig, Intrinsics, load_camera
from foos_core.markers import BALL_CENTRE_HEIGHT, MarkerLayout, load_markers
from foos_vision.camera.geometry import Lens, fit_mapping, tag_centre
from foos_vision.errors import CameraConfigError, MarkersError
from foos_vision.tracking.velocity import ConstantVelocityKalman, central_differences


def layout_at(z, heights=None):
    positions = {0: (-0.6, -0.7), 1: (0.6, -0.7), 2: (0.6, 0.7), 3: (-0.6, 0.7), 4: (-0.6, 0.0), 5: (0.6, 0.0)}
    zs = heights or {i: z for i in positions}
    return MarkerLayout("DICT_4X4_50", 0.06, {i: np.array([x, y, zs[i]]) for i, (x, y) in positions.items()})


def projected_tags(camera: CameraConfig, layout: MarkerLayout) -> dict[int, np.ndarray]:
    centres = {}
    for tag_id, p in layout.positions.items():
        s = layout.size / 2
        corners = np.array([p + (-s, s, 0), p + (s, s, 0), p + (s, -s, 0), p + (-s, -s, 0)])
        centres[tag_id] = tag_centre(camera.project(corners, distorted=False))
    return centres


BALLS = np.array([[0.0, 0.0], [0.3, 0.55], [-0.32, -0.58], [0.2, -0.3]])


@pytest.mark.parametrize("camera_name", ["overhead", "oblique"])
@pytest.mark.parametrize("tag_height", [BALL_CENTRE_HEIGHT, 0.0, 0.16])
def test_mapping_recovers_ball_centres_with_parallax(camera_name, tag_height):
    camera = load_camera(camera_name)
    layout = layout_at(tag_height)
    mapping = fit_mapping(projected_tags(camera, layout), layout, (camera.width, camera.height),
                          fovy_hint=camera.fovy)
    assert mapping.residual_m < 1e-4
    balls = np.c_[BALLS, np.full(len(BALLS), BALL_CENTRE_HEIGHT)]
    recovered = mapping.to_table(camera.project(balls, distorted=False))
    # The overhead view cannot tell its focal length from the tags alone: a 3 % wrong fov hint moves a
    # corner ball by well under a millimetre when the tags are 16 cm above it.
    assert np.max(np.linalg.norm(recovered - BALLS, axis=1)) < 1e-3


def test_tags_at_several_heights_use_a_projection_fit():
    camera = load_camera("oblique")
    layout = layout_at(0, heights={0: 0.0, 1: 0.05, 2: 0.16, 3: 0.0, 4: 0.1, 5: 0.02})
    mapping = fit_mapping(projected_tags(camera, layout), layout, (camera.width, camera.height))
    balls = np.c_[BALLS, np.full(len(BALLS), BALL_CENTRE_HEIGHT)]
    recovered = mapping.to_table(camera.project(balls, distorted=False))
    assert np.max(np.linalg.norm(recovered - BALLS, axis=1)) < 2e-4


def test_tag_centre_is_the_projected_centre_not_the_corner_mean():
    camera = load_camera("oblique")
    centre = np.array([0.5, 0.7, 0.0175])
    s = 0.03
    corners = camera.project(np.array([centre + (-s, s, 0), centre + (s, s, 0), centre + (s, -s, 0), centre + (-s, -s, 0)]),
                             distorted=False)
    truth = camera.project(centre[None], distorted=False)[0]
    assert np.linalg.norm(tag_centre(corners) - truth) < 1e-6


def test_lens_undistort_inverts_distort():
    camera = load_camera("overhead").with_(distortion=(-0.28, 0.09))
    lens = Lens(Intrinsics(camera.camera_matrix(), camera.dist_coeffs(), camera.width, camera.height))
    pixels = np.array([[10.0, 10.0], [320.0, 240.0], [600.0, 400.0]])
    assert np.allclose(lens.undistort(lens.distort(pixels)), pixels, atol=1e-3)


@pytest.mark.parametrize("coefficients", [(-0.3, 0.12, 0.001, -0.002, -0.02), (0.1, -0.05, 0.003, 0.0)])
def test_lens_distort_is_opencvs_model(coefficients):
    """Lens.distort computes OpenCV's (k1, k2, p1, p2, k3) model in numpy (placing the rods sends 100k points
    through it): the same pixels as cv2.projectPoints."""
    k = np.array([[579.4, 0.0, 319.5], [0.0, 571.2, 241.0], [0.0, 0.0, 1.0]])
    d = np.array(coefficients, float)
    pixels = np.random.default_rng(3).uniform((-50.0, -50.0), (690.0, 530.0), (2000, 2))
    normalised = np.column_stack([(pixels - k[:2, 2]) / np.diag(k)[:2], np.ones(len(pixels))])
    expected, _ = cv2.projectPoints(normalised.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), k, d)
    assert np.abs(Lens(Intrinsics(k, d, 640, 480)).distort(pixels) - expected.reshape(-1, 2)).max() < 1e-9


def test_fisheye_lens_maps_to_the_pinhole_of_the_same_camera_matrix():
    """Lens(fisheye) takes the image of cv2.fisheye to the ideal pinhole with the same K and back; it agrees
    with the camera's own projection; a fisheye with k = 0 is still no pinhole."""
    camera = CameraConfig(width=1920, height=1080, fovy=76.0, position=(0.0, 0.0, 1.0), model="fisheye",
                          distortion=(0.05, -0.02, 0.01, -0.005))
    lens = Lens(camera.intrinsics())
    points = np.array([[0.0, 0.0, 0.0175], [0.6, 0.7, 0.0175], [-0.34, 0.6, 0.0175], [0.3, -0.2, 0.1]])
    fisheye_pixels = camera.project(points)
    pinhole_pixels = camera.project(points, distorted=False)
    assert np.allclose(lens.undistort(fisheye_pixels), pinhole_pixels, atol=1e-3)
    assert np.allclose(lens.distort(pinhole_pixels), fisheye_pixels, atol=1e-3)
    # The table's corner is ~40 degrees off axis: the equidistant image is far inside the pinhole's.
    assert np.linalg.norm(pinhole_pixels[1] - fisheye_pixels[1]) > 50
    plain = Lens(camera.with_(distortion=(0.0, 0.0, 0.0, 0.0)).intrinsics())
    assert plain.active and not np.allclose(plain.undistort(fisheye_pixels[1:2]), fisheye_pixels[1:2])


def test_fisheye_render_camera_covers_the_image_up_to_its_size_limit():
    camera = load_camera("fisheye")
    assert camera.fisheye and (camera.width, camera.height, camera.fps) == (1920, 1080, 25.0)
    ideal = camera.render_camera()
    assert not ideal.fisheye and ideal.distortion == ()
    assert np.isclose(ideal.camera_matrix()[0, 0], camera.camera_matrix()[0, 0])  # as sharp at the centre
    assert ideal.width <= FISHEYE_RENDER_SCALE * camera.width and ideal.height <= FISHEYE_RENDER_SCALE * camera.height
    # Every tag of the shipped layout is inside the ideal render, so nothing on the table goes black.
    tags = np.array([[x, y, 0.0175] for x, y, _ in load_markers().positions.values()])
    pixels = ideal.project(tags, distorted=False)
    assert np.all((pixels > 0) & (pixels < (ideal.width, ideal.height)))


def test_too_few_or_foreign_tags_are_a_markers_error():
    camera = load_camera("overhead")
    layout = layout_at(BALL_CENTRE_HEIGHT)
    seen = projected_tags(camera, layout)
    with pytest.raises(MarkersError, match="at least 4"):
        fit_mapping({i: seen[i] for i in (0, 1, 2)}, layout, (640, 480))
    with pytest.raises(MarkersError, match="ids seen"):
        fit_mapping({i + 10: c for i, c in seen.items()}, layout, (640, 480))


@pytest.mark.parametrize("text, reason", [
    ("markers: {0: [0, 0, 0]}", "at least 4"),
    ("dictionary: DICT_NOPE\nmarkers: {0: [0,0,0], 1: [1,0,0], 2: [0,1,0], 3: [1,1,0]}", "dictionary"),
    ("markers: {0: [0, 0], 1: [1,0,0], 2: [0,1,0], 3: [1,1,0]}", "three finite"),
    ("markers: {0: [0,0,0], 1: [0.1,0,0], 2: [0.2,0,0], 3: [0.3,0,0]}", "one line"),
    ("markers: [", "YAML"),
])
def test_bad_markers_files(tmp_path, text, reason):
    path = tmp_path / "m.yaml"
    path.write_text(text)
    with pytest.raises(MarkersError, match=reason):
        load_markers(path)
    with pytest.raises(MarkersError, match="not found"):
        load_markers(tmp_path / "missing.yaml")


def test_shipped_configs_load():
    assert len(load_markers().positions) == 6
    for name in ("overhead", "oblique", "fisheye"):
        camera = load_camera(name)
        axes = camera.axes()
        assert np.allclose(axes @ axes.T, np.eye(3))
    with pytest.raises(CameraConfigError):
        load_camera("fisheye-from-nowhere")


def test_central_differences_are_exact_on_straight_lines_and_respect_gaps():
    t = np.array([0, 0.01, 0.02, 0.03, 0.5, 0.51])
    p = np.c_[2 * t, -t]
    v = central_differences(t, p)
    assert np.allclose(v, [[2, -1]] * len(t))
    assert np.all(np.isnan(central_differences(np.array([0.0]), np.array([[0.0, 0.0]]))))


def test_kalman_follows_constant_velocity_and_reports_its_uncertainty():
    rng = np.random.default_rng(0)
    kf = ConstantVelocityKalman(measurement_std=0.0015)
    for k in range(120):
        t = k / 120
        kf.update(t, np.array([1.5 * t, -0.8 * t]) + rng.normal(0, 0.0015, 2))
    assert np.linalg.norm(kf.state.x[2:] - (1.5, -0.8)) < 0.2
    speed_sigma = math.sqrt(np.trace(kf.state.P[2:, 2:]))
    assert 0.005 < speed_sigma < 0.3
    assert kf.predict(1.0 + 1.0) is None  # a long gap ends the track instead of extrapolating
