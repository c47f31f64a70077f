"""Auto colour on drawn frames: a red figure that passes for a moving ball now and then must not win
over an orange ball that is hidden while the colour is being chosen."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from foos_vision.camera.rod_lines import on_rod_line, rod_bands, rod_geometry
from foos_vision.detection.ball_colour import ROD_LINE_MIN_DX, ROD_LINE_Y_TOL, MovingBallVotes
from foos_vision.tracking.tracker import BallTracker, TrackerConfig

from .drawn_table import FPS, draw_ball, table_frame, write_layout

RED_BGR = (30, 30, 200)


@pytest.mark.timeout(60)
def test_a_figure_seen_now_and_then_does_not_settle_the_colour(tmp_path):
    layout = write_layout(tmp_path / "markers.yaml")
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto"))
    settled_at = None
    for k in range(120):
        frame = table_frame()
        if k % 5 == 0:
            # A red figure, sliding with its rod, that looks like a ball in one frame of five.
            draw_ball(frame, -0.2 + 0.004 * k, 0.075, RED_BGR)
        if k >= 40:
            draw_ball(frame, 0.1, -0.3 + 0.5 * (k - 40) / FPS)  # the orange ball, in view from frame 40
        tracker.process(cv2.GaussianBlur(frame, (3, 3), 0.7), k / FPS)
        if tracker.colour_settled and settled_at is None:
            settled_at = k
            assert tracker.colour.name == "orange", (k, tracker.colour.name)
    assert settled_at is not None and settled_at >= 40


def run_auto(layout, draw, frames: int = 60):
    """(colour, frame) where auto settles on drawn frames, or (None, None)."""
    tracker = BallTracker(layout, TrackerConfig(ball_color="auto"))
    for k in range(frames):
        frame = table_frame()
        draw(frame, k)
        tracker.process(cv2.GaussianBlur(frame, (3, 3), 0.7), k / FPS)
        if tracker.colour_settled:
            return tracker.colour.name, k
    return None, None


@pytest.mark.timeout(60)
def test_red_figures_sliding_on_their_rod_line_do_not_outvote_an_orange_ball(tmp_path):
    # A red figure on the rod at y = +0.075 slides along x and looks like a ball in two frames of three (its
    # lit edge has the orange ball's hue, so the orange prototype sees it too in the renders); the orange
    # ball rolls across the field in every frame. Counted as moving balls, the figure's frames kept the
    # ball's colour from leading clearly; its ball-plane y never leaves the rod's line, so it is no ball.
    layout = write_layout(tmp_path / "markers.yaml")

    def draw(frame, k):
        if k % 3 != 2:
            draw_ball(frame, -0.2 + 0.003 * k, 0.075 + 0.0004 * (k % 2), RED_BGR)
        draw_ball(frame, -0.25 + 0.6 * k / FPS, -0.45 + 1.2 * k / FPS)  # orange, crossing the rods at y -0.375, -0.225

    assert run_auto(layout, draw) == ("orange", 23)


@pytest.mark.timeout(60)
def test_a_red_ball_crossing_the_rod_lines_is_still_a_ball(tmp_path):
    # The rule is no blanket ban on the rod lines: a red ball rolling across them, past a red figure sliding
    # on its own line, still settles the colour on red.
    layout = write_layout(tmp_path / "markers.yaml")

    def draw(frame, k):
        draw_ball(frame, 0.15 - 0.003 * k, -0.225, RED_BGR)  # the figure
        draw_ball(frame, -0.2 + 0.4 * k / FPS, -0.30 + 1.5 * k / FPS, RED_BGR)  # the ball, over y = -0.225, -0.075

    assert run_auto(layout, draw) == ("red", 23)


def test_rod_bands_hold_a_hanging_figure_seen_with_parallax():
    rods = rod_geometry()
    assert rods.rod_y == (-0.525, -0.375, -0.225, -0.075, 0.075, 0.225, 0.375, 0.525)
    assert rods.top == pytest.approx(0.118) and rods.half_thickness == pytest.approx(0.011)
    bands = rod_bands(rods, np.array([0.0, 0.0, 1.0]), margin=0.0)
    # The head of the far goalie's figure, 0.118 m up, meets the ball plane farther out: y (1 - 0.0175) / (1 - 0.118).
    assert bands[-1, 1] == pytest.approx(0.536 * 0.9825 / 0.882)
    assert bands[-1, 0] == pytest.approx(0.514 * 0.9825 / 1.0)
    assert bands[3, 0] < -0.075 < bands[3, 1]
    assert on_rod_line(0.56, bands) and not on_rod_line(0.45, bands) and not on_rod_line(0.0, bands)


def brute_force_votes(frames, bands):
    """MovingBallVotes' definition, checked pair by pair over the whole window."""
    def fixture(p, own):
        return any(np.hypot(p[0] - q[0], p[1] - q[1]) < 2.0 for j, f in enumerate(frames) if abs(j - own) >= 6 for q in f)

    def figure(p, own):
        return on_rod_line(p[3], bands) and any(
            abs(p[3] - q[3]) < ROD_LINE_Y_TOL and abs(p[2] - q[2]) >= ROD_LINE_MIN_DX
            for j, f in enumerate(frames) if abs(j - own) >= 6 for q in f)

    return sum(1 for i, f in enumerate(frames) if len([p for p in f if not fixture(p, i) and not figure(p, i)]) == 1)


@pytest.mark.parametrize("window", [7, 25])
def test_moving_ball_votes_counted_as_blobs_come_and_leave_the_window_match_the_definition(window):
    # The counts are kept per blob as frames arrive and leave (a live feed may wait minutes for its ball);
    # after every frame they must equal the pairwise definition over the window.
    rng = np.random.default_rng(window)
    bands = np.array([[-0.05, 0.0], [0.2, 0.23]])
    votes, frames = MovingBallVotes(bands, window=window), []
    for _ in range(80):
        frame = []
        for _ in range(rng.integers(0, 4)):
            if rng.random() < 0.4:  # a fixture's pixel, on a rod line somewhere along x
                frame.append((100.0 + rng.integers(0, 3), 50.0 + rng.integers(0, 3), rng.uniform(-0.3, 0.3),
                              rng.choice([-0.02, 0.21]) + rng.normal(0.0, 0.002)))
            else:
                frame.append((rng.uniform(0, 640), rng.uniform(0, 480), rng.uniform(-0.3, 0.3), rng.uniform(-0.6, 0.6)))
        frames.append(frame)
        votes.add(frame)
        assert votes.frames == len(frames[-window:])
        assert votes.votes() == brute_force_votes(frames[-window:], bands)
