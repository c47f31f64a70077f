"""A motion-blurred ball (foos_vision.detection.streaks): drawn streaks with a known mid-exposure centre, found and placed where a
rod crosses them, a figure hides an end or one side, a figure's blended edge is beside them, or the ball was struck from
rest; a track started from streaks; what is not a streak; and the Kalman filter's covariance per detection. The tracker
on rendered shots: test_streaks_video.py."""
from __future__ import annotations

import math

import numpy as np
import pytest

from foos_vision.detection.candidate_rules import STREAK_WIDTH, streak_ball
from foos_vision.detection.streaks import find_streaks
from foos_vision.tracking.tracker import BallTracker, TrackerConfig
from foos_vision.tracking.velocity import ConstantVelocityKalman

from .drawn_table import draw_ball, table_frame

FELT = np.array([51.0, 133.0, 27.0])  # BGR of the rendered felt
YELLOW = np.array([40.0, 235.0, 255.0])  # BGR of a yellow ball's lit top
SHADING = 0.5  # the ball's rim is this much darker than its top: lit from above, the mean of its inner disc (the
# colour the tracker learns) is 1 / 0.89 of the whole disc's, as on the renders
SIZE = (240, 360)  # h, w
RADIUS = 8.0  # px
SUPERSAMPLE = 3


def exposure(path: list, ball=YELLOW, felt=FELT, noise: float = 1.5, seed: int = 0) -> np.ndarray:
    """The mean of frames of the felt with the ball's disc at each point of path (pixels): a frame exposed while the
    ball went along it, as a camera integrates it (shaded, anti-aliased discs, sensor noise)."""
    h, w = SIZE
    ys, xs = np.mgrid[0:h * SUPERSAMPLE, 0:w * SUPERSAMPLE]
    xs, ys = (xs + 0.5) / SUPERSAMPLE - 0.5, (ys + 0.5) / SUPERSAMPLE - 0.5
    total = np.zeros((h, w, 3), np.float64)
    for centre in path:
        d2 = ((xs - centre[0]) ** 2 + (ys - centre[1]) ** 2) / RADIUS ** 2
        inside = d2 <= 1.0
        shade = np.where(inside, 1.0 - SHADING * d2, 0.0)
        cover = inside.reshape(h, SUPERSAMPLE, w, SUPERSAMPLE).mean(axis=(1, 3))[..., None]
        lit = shade.reshape(h, SUPERSAMPLE, w, SUPERSAMPLE).mean(axis=(1, 3))[..., None]
        total += lit * ball + (1.0 - cover) * felt
    image = total / len(path) + np.random.default_rng(seed).normal(0.0, noise, (h, w, 3))
    return np.clip(image + 0.5, 0, 255).astype(np.uint8)


def learned_colour(ball=YELLOW) -> np.ndarray:
    """What the tracker learns from a whole ball at rest: the mean colour within 0.8 radii (BallSearch.note_whole_ball)."""
    image = exposure([np.array([180.0, 120.0])], ball, noise=0.0)
    ys, xs = np.mgrid[0:SIZE[0], 0:SIZE[1]]
    return image[(xs - 180.0) ** 2 + (ys - 120.0) ** 2 <= (0.8 * RADIUS) ** 2].astype(np.float64).mean(axis=0)


def moving(start, end, steps: int = 96, rest: float = 0.0) -> list[np.ndarray]:
    """Centres over an exposure: resting at start for a share `rest` of it, then uniformly to end."""
    start, end = np.asarray(start, float), np.asarray(end, float)
    times = (np.arange(steps) + 0.5) / steps
    return [start if t < rest else start + (t - rest) / (1.0 - rest) * (end - start) for t in times]


def mid_exposure(start, end, rest: float = 0.0) -> np.ndarray:
    start, end = np.asarray(start, float), np.asarray(end, float)
    return start if rest >= 0.5 else start + (0.5 - rest) / (1.0 - rest) * (end - start)


def streaks_in(image: np.ndarray) -> list:
    h, w = SIZE
    return find_streaks(image, (0, 0, w, h), lambda u, v: RADIUS, learned_colour(), FELT, width=STREAK_WIDTH)


def the_streak(image: np.ndarray, near: np.ndarray):
    found = [s for s in streaks_in(image) if streak_ball(s, RADIUS)]
    assert found, "no streak found"
    return min(found, key=lambda s: math.hypot(s.u - near[0], s.v - near[1]))


# 17, 13 and 3 radii long: a shot at 8, 6 and 1.5 m/s filmed at 25 fps with the shutter open all of the frame interval
# (longer than about 20 radii, a streak's shares fall to the noise's).
@pytest.mark.parametrize("start,end", [((100.3, 100.0), (235.0, 124.6)), ((250.0, 60.0), (170.5, 141.2)),
                                       ((100.0, 120.0), (124.0, 120.0))])
def test_a_streak_is_found_at_its_mid_exposure_centre(start, end):
    image = exposure(moving(start, end))
    s = the_streak(image, mid_exposure(start, end))
    truth = mid_exposure(start, end)
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 0.5, (s.u, s.v, truth)
    length = math.hypot(end[0] - start[0], end[1] - start[1])
    assert abs(s.motion - length) < 0.05 * length + 1.0, (s.motion, length)
    # The shares add up to a disc: those over ALPHA_MIN, most of it (a long streak's faint sides are below), and the
    # fitted model's (its contrast against the learned colour's, that of the lit top: 0.89).
    assert 0.6 < s.area_ratio < 1.0 and 0.85 < s.contrast < 0.95 and s.explained > 0.9, s
    assert abs(abs(float(np.dot(s.axis, np.subtract(end, start)))) / length - 1.0) < 0.01


def test_a_rod_across_the_streak_and_a_figure_over_its_end_do_not_move_it():
    start, end = (100.0, 120.0), (230.0, 128.0)
    image = exposure(moving(start, end))
    image[:, 150:158] = (120, 122, 125)  # a steel rod across the middle: in front of the ball
    image[100:150, 215:260] = (200, 50, 25)  # a blue figure over the far end
    truth = mid_exposure(start, end)
    s = the_streak(image, truth)
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 1.5, (s.u, s.v, truth)
    # The centroid of the shares seen is pulled toward what shows: the fit is what places it.
    assert math.hypot(s.cu - truth[0], s.cv - truth[1]) > 5.0


@pytest.mark.parametrize("rest", [0.2, 0.4])
def test_a_ball_struck_from_rest_is_where_it_was_at_mid_exposure(rest):
    start, end = (80.0, 110.0), (180.0, 130.0)  # 13 radii in 60-80 % of the exposure
    image = exposure(moving(start, end, rest=rest))
    truth = mid_exposure(start, end, rest)
    s = the_streak(image, truth)
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 1.5, (s.u, s.v, truth, s.rest)


# A figure over the streak's middle (the ball passed under it), and one beside the streak, touching it.
@pytest.mark.parametrize("rows", [(104, 140), (84, 114)])
def test_a_streak_that_touches_a_figure_of_its_colour_is_found_without_the_mask(rows):
    # The ball passes a figure of its own colour on a rod: streak and figure are one blob, too solid to be a streak.
    # The rod's axis tells the figure (solid ball colour over it) from the ball, which is below the rods.
    start, end = (100.0, 120.0), (230.0, 128.0)
    image = exposure(moving(start, end))
    image[:, 150:158] = (120, 122, 125)  # the steel rod across the streak
    image[rows[0]:rows[1], 144:164] = learned_colour().astype(np.uint8)  # the figure, over the rod
    axes = np.zeros(SIZE, np.uint8)
    axes[:, 154] = 255
    truth = mid_exposure(start, end)
    h, w = SIZE
    found = {with_axes: [s for s in find_streaks(image, (0, 0, w, h), lambda u, v: RADIUS, learned_colour(), FELT,
                                                 width=STREAK_WIDTH, rod_axes=axes if with_axes else None)
                         if streak_ball(s, RADIUS)] for with_axes in (False, True)}
    assert not found[False]
    assert len(found[True]) == 1, found[True]
    s = found[True][0]
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 1.5, (s.u, s.v, truth)
    # The figure alone, on its rod, is no streak.
    alone = exposure([np.array([-100.0, -100.0])])
    alone[:, 150:158] = (120, 122, 125)
    alone[104:140, 144:164] = learned_colour().astype(np.uint8)
    assert not [s for s in find_streaks(alone, (0, 0, w, h), lambda u, v: RADIUS, learned_colour(), FELT,
                                        width=STREAK_WIDTH, rod_axes=axes) if streak_ball(s, RADIUS)]


PALE = np.array([150.0, 245.0, 255.0])  # BGR of a yellow figure's lit top, paler than the ball: off the ball-felt plane


def lying_figure(image: np.ndarray, top: int, bottom: int, left: int, right: int, edge: float = 0.0) -> None:
    """A figure lying level (a bar of PALE); edge > 0: its outline a pixel wide, a blend of that much of the ball's
    colour with the felt (its sides, in the ball's yellow, anti-aliased), which passes for a faint share of the ball."""
    if edge > 0:
        ring = (slice(top - 1, bottom + 1), slice(left - 1, right + 1))
        image[ring] = (edge * learned_colour() + (1.0 - edge) * image[ring]).astype(np.uint8)
    image[top:bottom, left:right] = PALE.astype(np.uint8)


def test_a_streak_that_a_figure_hides_along_one_side_is_found():
    # A short streak (3.5 radii: a shot at 60 fps) under a figure lying level that hides it from a quarter radius
    # below its middle line along its whole length: what shows is 0.6 of a disc wide, narrower than a streak by its
    # moments.
    start, end = (150.0, 120.0), (178.0, 121.0)
    truth = mid_exposure(start, end)
    image = exposure(moving(start, end))
    for x in range(60, 280):
        image[int(round(start[1] + (x - start[0]) / (end[0] - start[0]))) + 2:150, x] = PALE.astype(np.uint8)
    s = the_streak(image, truth)
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 1.0, (s.u, s.v, truth)
    assert STREAK_WIDTH[0] <= s.width_ratio <= STREAK_WIDTH[1]  # the fitted streak's, the hidden side the model's
    # Hidden from its middle line (half a disc's width seen): its path across is a guess from an edge, not measured.
    image = exposure(moving(start, end))
    image[121:150, 60:280] = PALE.astype(np.uint8)
    assert not [s for s in streaks_in(image) if streak_ball(s, RADIUS)]


@pytest.mark.parametrize("gap", [4, 8])
def test_a_streak_beside_the_blended_edge_of_a_figure_is_found(gap):
    # Between two figures lying level whose outlines blend the ball's colour with the felt: grouped with such an
    # outline, the streak is one blob twice a disc wide. Apart from what hides the ball, it is a streak.
    start, end = (150.0, 120.0), (178.0, 121.0)
    truth = mid_exposure(start, end)
    image = exposure(moving(start, end))
    lying_figure(image, 130 + gap, 150 + gap, 60, 200, edge=0.3)
    lying_figure(image, 82 - gap, 102 - gap, 150, 280, edge=0.3)
    s = the_streak(image, truth)
    assert math.hypot(s.u - truth[0], s.v - truth[1]) < 1.0, (s.u, s.v, truth)


def test_a_track_starts_from_a_streak(layout):
    # The ball at rest (its colour learned), picked up, then rolled into view at 2.8 m/s, filmed at 30 fps with the
    # shutter open half the frame: a streak 2.7 radii long in every frame, which the colour box takes only the middle
    # of. Seen twice running, it starts a track, as a ball-like blob does.
    fps, exposure_share, speed = 30.0, 0.5, np.array([0.6, 0.8]) * 2.8
    felt = table_frame()

    def streak_at(centre: np.ndarray, seed: int) -> np.ndarray:
        total = np.zeros(felt.shape, np.float64)
        for share in (np.arange(24) + 0.5) / 24 - 0.5:
            image = felt.copy()
            draw_ball(image, *(centre + share * exposure_share / fps * speed))
            total += image
        noisy = total / 24 + np.random.default_rng(seed).normal(0.0, 1.5, felt.shape)
        return np.clip(noisy + 0.5, 0, 255).astype(np.uint8)

    tracker = BallTracker(layout, TrackerConfig(ball_color="orange"))
    for k in range(6):
        at_rest = felt.copy()
        draw_ball(at_rest, 0.15, 0.3)
        assert tracker.process(at_rest, k / fps) is not None
    for k in range(6, 18):  # picked up: the track ends
        assert tracker.process(felt.copy(), k / fps) is None
    errors = []
    for k in range(18, 28):
        centre = np.array([-0.25, -0.45]) + (k - 18) / fps * speed
        found = tracker.process(streak_at(centre, k), k / fps)
        errors.append(None if found is None else math.hypot(found.x - centre[0], found.y - centre[1]))
    assert errors[0] is None  # one sighting starts no track
    assert all(e is not None and e < 0.0015 for e in errors[1:]), errors


def test_what_is_not_a_streak():
    # A figure of the ball's colour lying level (a bar of solid colour), a steel rod's white highlight for a white
    # ball (a line), and a ball at rest: none is a streak of a moving ball.
    bar = exposure([np.array([-100.0, -100.0])])
    bar[100:124, 100:210] = learned_colour().astype(np.uint8)
    assert not [s for s in streaks_in(bar) if streak_ball(s, RADIUS)]
    white, grey = learned_colour(np.array([240.0, 240.0, 240.0])), np.array([120.0, 122.0, 125.0])
    line = exposure([np.array([-100.0, -100.0])])
    line[:, 150:158] = grey.astype(np.uint8)
    line[:, 153:155] = white.astype(np.uint8)
    h, w = SIZE
    assert not [s for s in find_streaks(line, (0, 0, w, h), lambda u, v: RADIUS, white, FELT, width=STREAK_WIDTH)
                if streak_ball(s, RADIUS)]
    still = exposure(moving((180.0, 120.0), (180.0, 120.0)))
    assert not [s for s in streaks_in(still) if streak_ball(s, RADIUS)]


def test_the_filter_trusts_a_streak_across_more_than_along():
    along = np.array([1.0, 0.0])
    covariance = 1.5e-3 ** 2 * np.eye(2) + (8e-3 ** 2 - 1.5e-3 ** 2) * np.outer(along, along)
    moved = {}
    for name, offset in (("along", (0.01, 0.0)), ("across", (0.0, 0.01))):
        kalman = ConstantVelocityKalman()
        for k in range(5):
            kalman.update(0.04 * k, (0.0, 0.0))
        state = kalman.update(0.2, offset, covariance)
        moved[name] = float(np.linalg.norm(state.x[:2]))
    assert moved["across"] > 1.5 * moved["along"], moved
    # A measurement far along the streak is within its uncertainty: no restart (the velocity is kept).
    kalman = ConstantVelocityKalman()
    for k in range(5):
        kalman.update(0.04 * k, (0.04 * k, 0.0))
    state = kalman.update(0.2, (0.2 + 0.02, 0.0), covariance)
    assert state.x[2] > 0.5
