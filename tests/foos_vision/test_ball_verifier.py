"""ball_verifier: the shipped weights load offline and tell a rendered ball from a rendered line and a white figure's
foot (a sock); a bad weights file is one line; the verified pick keeps or vetoes the rules' pick."""
from __future__ import annotations

import math
import subprocess
import sys

import cv2
import numpy as np
import pytest

from foos_vision.detection import still_ball
from foos_vision.detection.ball_verifier import (
    DEFAULT_WEIGHTS,
    PATCH,
    BallVerifier,
    VerifierError,
    normalise,
    raw_patches,
)
from foos_vision.detection.still_ball import FeltField, StillCandidate


def test_the_shipped_weights_are_small_and_load():
    assert DEFAULT_WEIGHTS.stat().st_size <= 300 * 1024
    verifier = BallVerifier()
    assert verifier.probability(np.zeros((0, 3, PATCH, PATCH), np.float32)).shape == (0,)


def _render_with_white_team_and_a_line():
    """A 1280x720 overhead render: a white ball at (0.10, -0.15) m between the rods, the home team white (its feet are
    socks of the ball's colour), and a white line painted across the felt at y = 0.30 m. Returns the image, the ball's
    pixel, a pixel on the line, the home attackers' feet's pixels and the ball's radius in px."""
    from foos_core.camera_model import load_camera
    from foos_core.markers import load_markers
    from foos_sim.camera.render import RenderOptions, SceneRenderer
    from foos_sim.camera.scene import BALL_COLOURS
    from foos_sim.model_builder import build_mjcf
    from foos_sim.simulation import TableSimulation

    camera = load_camera("overhead").with_(width=1280, height=720)
    options = RenderOptions(camera=camera, ball_colour=BALL_COLOURS["white"], home_colour=(0.92, 0.92, 0.90),
                            shadows=True, seed=3)
    renderer = SceneRenderer(build_mjcf(None), load_markers(), options)
    try:
        sim = TableSimulation()
        sim.reset(ball_position=(0.10, -0.15), ball_velocity=(0.0, 0.0))
        qpos = sim.data.qpos.copy()
        image = renderer.finish([renderer.render_rgb(qpos)])
        feet = np.array([renderer.data.geom(f"home_attack_figure{i}_foot").xpos for i in range(3)])
    finally:
        renderer.close()
    centre = sim.ball_position()[None, :]
    ball = camera.project(centre)[0]
    radius = camera.camera_matrix()[0, 0] * sim.ball_radius / float(camera.depth(centre)[0])
    ends = camera.project(np.array([[-0.30, 0.30, 0.0], [0.30, 0.30, 0.0]]))
    # Painted on the felt only (the figures and rods stay in front of it), as thick as half the ball.
    painted = image.copy()
    cv2.line(painted, tuple(int(v) for v in ends[0]), tuple(int(v) for v in ends[1]), (235, 235, 235),
             max(2, int(radius)), cv2.LINE_AA)
    lab = cv2.cvtColor(image, cv2.COLOR_BGR2Lab).astype(np.int16)
    felt_ab = np.median(lab[300:420, 540:740, 1:].reshape(-1, 2), axis=0)
    felt = np.all(np.abs(lab[..., 1:] - felt_ab) <= 10, axis=2)
    image[felt] = painted[felt]
    line_point = camera.project(np.array([[0.17, 0.30, 0.0]]))[0]  # between the figures on the line
    return image, ball, line_point, camera.project(feet), radius


@pytest.mark.timeout(120)
def test_the_verifier_tells_a_rendered_ball_from_a_line_and_a_sock():
    image, ball, line_point, feet, radius = _render_with_white_team_and_a_line()
    verifier = BallVerifier()
    centres = [tuple(ball), tuple(line_point)] + [tuple(f) for f in feet]
    chances = verifier.score(image, centres, radius)
    assert chances[0] >= 0.8, chances
    assert np.all(chances[1:] <= 0.3), chances
    # Random weights of the same shapes do not do this: the test needs what training learned.
    rng = np.random.default_rng(0)
    for trial in range(3):
        shuffled = BallVerifier()
        shuffled.params = {k: rng.normal(0, 0.3, v.shape).astype(np.float32) for k, v in verifier.params.items()}
        random_chances = shuffled.score(image, centres, radius)
        assert not (random_chances[0] >= 0.8 and np.all(random_chances[1:] <= 0.3)), (trial, random_chances)


def test_patches_scale_the_ball_to_the_patch():
    image = np.full((400, 600, 3), (40, 120, 40), np.uint8)
    cv2.circle(image, (300, 200), 20, (240, 240, 240), -1)
    raw = raw_patches(image, [(300, 200), (100, 100)], 20.0)
    assert raw.shape == (2, PATCH, PATCH, 3)
    x = normalise(raw)
    assert x.shape == (2, 3, PATCH, PATCH)
    # The ball fills a disc of PATCH_BALL_RADIUS (7 px) at the centre; the border is the felt (0 after normalising).
    lit = np.count_nonzero(x[0, 0] > 1.0)
    assert abs(lit - math.pi * 7 ** 2) < 0.25 * math.pi * 7 ** 2
    assert np.all(x[1] == 0.0)


@pytest.mark.parametrize("content, message", [
    (None, "no such ball verifier weights file"),
    (b"not an npz", "not a ball verifier weights file"),
    ({"conv1.w": np.zeros((8, 3, 3, 3))}, "no conv1.b"),
    ("shapes", "conv2 has shape"),
    ("nan", "not all finite"),
])
def test_a_bad_weights_file_is_one_line(tmp_path, content, message):
    path = tmp_path / "weights.npz"
    if isinstance(content, bytes):
        path.write_bytes(content)
    elif isinstance(content, dict):
        np.savez(path, **content)
    elif content in ("shapes", "nan"):
        params = dict(BallVerifier().params)
        if content == "shapes":
            params["conv2.w"] = np.zeros((16, 4, 3, 3), np.float32)
        else:
            params["fc1.b"] = np.full_like(params["fc1.b"], np.nan)
        np.savez(path, **params)
    with pytest.raises(VerifierError) as error:
        BallVerifier(path)
    assert message in str(error.value) and "\n" not in str(error.value)


def test_bench_with_a_bad_weights_file_says_one_line_and_fails(tmp_path):
    bad = tmp_path / "bad.npz"
    bad.write_text("no weights")
    run = subprocess.run([sys.executable, "-m", "foos_vision.bench", "--still-renders", "--verifier", str(bad)],
                         capture_output=True, text=True, timeout=120)
    assert run.returncode == 2
    lines = run.stderr.strip().splitlines()
    assert len(lines) == 1 and "not a ball verifier weights file" in lines[0], run.stderr


def _candidate(u, score, verified, cue="light"):
    return StillCandidate(u, 500.0, 10.0, 20.0, score, 1.0, 0.0, score, cue, verified)


FIELD = FeltField(np.zeros((4, 2)), (120.0, 100.0, 140.0), 10.0, 0.5)


def test_the_verifier_vetoes_a_rules_pick_it_calls_no_ball():
    pick = [_candidate(100.0, 0.9, still_ball.VETO_BELOW - 0.1), _candidate(500.0, 0.3, 0.1)]
    assert still_ball._pick(pick, FIELD) is pick[0]
    assert still_ball._verified_pick(pick, FIELD) is None
    pick[0].verified = still_ball.VETO_BELOW + 0.1
    assert still_ball._verified_pick(pick, FIELD) is pick[0]


def test_the_verifier_picks_where_the_rules_pick_none():
    sure = still_ball.MIN_VERIFIED + 0.05
    candidates = [_candidate(100.0, 0.5, 0.2), _candidate(500.0, 0.3, sure)]
    assert still_ball._pick(candidates, FIELD) is None
    assert still_ball._verified_pick(candidates, FIELD) is candidates[1]
    # A rival the verifier is nearly as sure of, more than a ball's width away: a guess, no pick.
    candidates.append(_candidate(900.0, 0.2, sure - still_ball.MIN_VERIFIED_LEAD / 2))
    assert still_ball._verified_pick(candidates, FIELD) is None
