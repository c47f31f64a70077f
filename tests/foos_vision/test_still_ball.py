"""still_ball: the felt and the ball in one frame, nothing else given: drawn frames for each rule, and renders of the
simulated camera (foos_sim.camera) for a ball of each colour among the rendered table's figures, rods and walls."""
from __future__ import annotations

import math

import cv2
import numpy as np
import pytest

from foos_vision.detection import still_ball
from foos_vision.detection.still_ball import (
    MIN_LEAD,
    MIN_SCORE,
    MIN_TINT_SCORE,
    TEAM_BALLS,
    FeltField,
    StillBallFinder,
    StillCandidate,
)

# Eight steel rods (16 mm: 18 px) across the field's width, 150 mm apart, past the felt on both sides, as on a table.
RODS_U = sorted(960 + side * d for d in (87, 261, 435, 609) for side in (-1, 1))


def drawn_still(ball=(1200, 500), ball_bgr=(235, 235, 235), heads_bgr=(30, 30, 30), felt_bgr=(60, 130, 50),
                rods=True):
    """A 1920x1080 frame: grey floor, a felt (green unless told) 1400 x 790 px (a 1.2 x 0.68 m field at 1160 px/m),
    white lines, figures' heads of the ball's size, and a ball (35 mm: 40.6 px across; none when ball is None).
    rods: the eight rods across the felt at the regulation spacing (RODS_U), thin and in shade (dark), under the ball
    and the lines: a felt is crossed by its rods (still_ball.MIN_ROD_LINES), and dark rods add no light near a ball."""
    frame = np.full((1080, 1920, 3), (90, 90, 90), np.uint8)
    cv2.rectangle(frame, (260, 145), (1660, 935), felt_bgr, -1)
    if rods:
        for u in RODS_U:
            cv2.rectangle(frame, (u - 3, 0), (u + 3, 1079), (40, 40, 40), -1)
    cv2.line(frame, (960, 145), (960, 935), (240, 240, 240), 6)
    cv2.circle(frame, (960, 540), 120, (240, 240, 240), 6)
    for u in (500, 700, 1400):
        cv2.circle(frame, (u, 300), 20, heads_bgr, -1)
    if ball is not None:
        cv2.circle(frame, ball, 20, ball_bgr, -1, cv2.LINE_AA)
    return cv2.GaussianBlur(frame, (5, 5), 1.0)


def test_the_field_and_the_ball_are_found():
    finder = StillBallFinder()
    field, candidates = finder.find(drawn_still())
    assert field is not None and 0.4 < field.share < 0.7
    assert abs(field.ball_radius_px - 20.3) < 2.0, field.ball_radius_px
    assert candidates and math.hypot(candidates[0].u - 1200, candidates[0].v - 500) < 3.0, candidates[:2]
    _, ball = finder.ball(drawn_still())
    assert ball is not None and ball.score >= MIN_SCORE and ball.rim == 1.0, ball


def test_a_yellow_ball_needs_no_colour_given():
    field, candidates = StillBallFinder().find(drawn_still(ball=(700, 800), ball_bgr=(40, 210, 230)))
    assert candidates and math.hypot(candidates[0].u - 700, candidates[0].v - 800) < 3.0, candidates[:2]


def test_lines_and_a_rods_highlight_are_no_ball():
    # No ball: white lines, and a light streak along a rod (a lamp's reflection), as wide as the ball and 4 balls long.
    frame = drawn_still(ball=None)
    cv2.line(frame, (260, 650), (1660, 650), (120, 120, 120), 14)
    cv2.ellipse(frame, (1100, 650), (80, 10), 0, 0, 360, (250, 250, 250), -1, cv2.LINE_AA)
    finder = StillBallFinder()
    field, candidates = finder.find(frame)
    assert field is not None
    assert finder.ball(frame)[1] is None, candidates[:2]
    streak = [c for c in candidates if abs(c.v - 650) < 20 and abs(c.u - 1100) < 100]
    assert all(c.rim < 0.75 for c in streak), streak


def test_a_rods_highlight_against_a_figure_is_not_round():
    # A lamp's reflection on a rod, cut off by a dark figure on the rod: a light patch of the ball's width with a
    # straight end, the commonest wrong pick on real tables. Its edges are straight: few lie on a circle.
    frame = drawn_still(ball=(1200, 500))
    cv2.ellipse(frame, (640, 760), (80, 18), 0, 0, 360, (250, 250, 250), -1, cv2.LINE_AA)
    cv2.rectangle(frame, (560, 730), (600, 800), (25, 25, 25), -1)
    field, candidates = StillBallFinder().find(frame)
    ball = min(candidates, key=lambda c: math.hypot(c.u - 1200, c.v - 500))
    reflection = [c for c in candidates if abs(c.v - 760) < 25 and 580 < c.u < 730]
    assert reflection and ball.rim >= 0.9 and max(c.rim for c in reflection) <= 0.75, (ball, reflection)


def rods_still(ball=(1134, 500), foot=True):
    """drawn_still with rods, a lamp's reflection on one rod cut off by a dark figure (32 px across: wider than the
    rod, near the ball's 40), and a ball between two rods, its upper right hidden by a figure's foot (foot=True)."""
    frame = drawn_still(ball=None, rods=False)
    for u in RODS_U:
        cv2.rectangle(frame, (u - 9, 0), (u + 9, 1079), (150, 150, 150), -1)
        for edge in (u - 9, u + 9):
            cv2.line(frame, (edge, 0), (edge, 1079), (60, 60, 60), 2)
    rod = RODS_U[4]
    cv2.ellipse(frame, (rod, 700), (16, 40), 0, 0, 360, (250, 250, 250), -1, cv2.LINE_AA)
    cv2.rectangle(frame, (rod - 22, 660), (rod + 22, 690), (25, 25, 25), -1)
    if ball is not None:
        cv2.circle(frame, ball, 20, (235, 235, 235), -1, cv2.LINE_AA)
        if foot:
            cv2.rectangle(frame, (ball[0] + 4, ball[1] - 30), (ball[0] + 34, ball[1] + 2), (25, 25, 25), -1)
    return cv2.GaussianBlur(frame, (5, 5), 1.0)


def test_the_rods_are_found_as_whole_lines():
    frame = rods_still(ball=None)
    # A painted line along the field's length, across the rods: straight and across the felt, but not a rod.
    cv2.line(frame, (260, 820), (1660, 820), (240, 240, 240), 6)
    for u in RODS_U:
        cv2.rectangle(frame, (u - 8, 810), (u + 8, 830), (150, 150, 150), -1)
    scale = still_ball.WORK_WIDTH / 1920
    small = cv2.resize(frame, (still_ball.WORK_WIDTH, round(1080 * scale)), interpolation=cv2.INTER_AREA)
    lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
    _, region = StillBallFinder()._felt(lab, scale)
    rods = still_ball._rod_lines(lab, region)
    for y in (300, 540, 800):  # across the felt, above and below the reflection (full-frame rows and columns)
        on = np.flatnonzero(rods[round(y * scale)]) / scale
        assert all(np.any(np.abs(on - u) <= 12) for u in RODS_U), (y, on)  # each rod has a line on it
    # Every line found lies within a rod's width (18 px) of a rod's axis or of the painted centre line, parallel to
    # them (the rods' edges are 9 px off the axis, and lines within half a degree of them fan out by a few px).
    # The felt's long edges and the painted line along the field are straight lines across the felt too, but not in
    # the rods' direction.
    for y in (146, 300, 540, 800, 820, 934):
        on = np.flatnonzero(rods[round(y * scale)]) / scale
        assert all(min(abs(u - x) for x in [*RODS_U, 960]) <= 18 for u in on), (y, on)


def test_one_line_stands_for_an_edges_fan():
    # An edge 400 px long across the felt at x = 100 answers in neighbouring Hough cells: a line 1 px over, one turned
    # by the angle step about the edge's middle (1.7 px off at its ends). One line, the one with the most edge on it,
    # stands for them; a rod's other edge, 9 px over, is a line of its own.
    def line(x0, x1, weight):
        ends = np.array([[x0, 0.0], [x1, 400.0]])
        theta = math.atan2(x0 - x1, 400.0)  # the normal (cos, sin) of the line through the two ends
        return (x0 * math.cos(theta), theta, weight, ends)

    step = 200 * math.tan(math.radians(still_ball.ROD_ANGLE_STEP))
    fan = [line(100, 100, 380), line(101, 101, 300), line(100 - step, 100 + step, 290), line(109, 109, 350)]
    kept = still_ball._one_line_per_edge(fan)
    assert [round(w) for _, _, w in kept] == [380, 350], kept


def test_a_rods_reflection_does_not_outshine_a_half_hidden_ball():
    # The commonest miss on real tables: a ball at a figure's foot scores less than a perfect disc, and a lamp's
    # reflection on a rod, cut off by a figure, comes near it or beats it. The reflection lies on the rod's lines:
    # their light is taken out, and the ball leads.
    frame = rods_still()
    finder = StillBallFinder()
    field, ball = finder.ball(frame)
    assert ball is not None and math.hypot(ball.u - 1134, ball.v - 500) < 5, finder.find(frame)[1][:3]
    reflection = [c for c in finder.find(frame)[1] if abs(c.u - RODS_U[4]) < 25 and abs(c.v - 700) < 45]
    assert all(c.score <= ball.score - MIN_LEAD for c in reflection), (ball, reflection)


def test_a_ball_touching_a_rod_is_found():
    # A ball beside a rod, touching it, lies off the rod's axis: its light is kept.
    frame = rods_still(ball=(RODS_U[5] - 9 - 20, 400), foot=False)
    _, ball = StillBallFinder().ball(frame)
    assert ball is not None and math.hypot(ball.u - (RODS_U[5] - 29), ball.v - 400) < 5, ball


def test_two_balls_alike_are_a_guess_not_a_pick():
    # Two equally ball-like discs far apart: either could be the ball, so none is reported (a wrong ball costs more
    # than none); the candidates still list both.
    frame = drawn_still(ball=(1200, 500))
    cv2.circle(frame, (600, 800), 20, (235, 235, 235), -1, cv2.LINE_AA)
    finder = StillBallFinder()
    field, candidates = finder.find(frame)
    assert abs(candidates[0].score - candidates[1].score) < MIN_LEAD, candidates[:2]
    assert {round(candidates[0].u, -2), round(candidates[1].u, -2)} == {1200, 600}, candidates[:2]
    assert finder.ball(frame)[1] is None


def test_the_centre_is_the_balls_not_its_lit_top():
    # A ball lit from above: its top half light, its lower half close to the felt's light. The rim's circle gives the
    # whole ball's centre, below the light's peak.
    frame = drawn_still(ball=None)
    cv2.circle(frame, (1200, 500), 20, (75, 145, 65), -1, cv2.LINE_AA)
    cv2.ellipse(frame, (1200, 500), (20, 20), 0, 180, 360, (235, 235, 235), -1, cv2.LINE_AA)
    _, ball = StillBallFinder().ball(frame)
    assert ball is not None and math.hypot(ball.u - 1200, ball.v - 500) < 5.0, ball


# (felt, the shaded ball's body), BGR: a yellow ball on green felt (Lab L 137 on the felt's 123), an orange one on blue
# felt (L 108 on 97). Each body is only 11-14 light levels above the felt, as a real ball in a figure's shade is.
SHADED_BALLS = [((60, 130, 50), (40, 130, 140)), ((150, 90, 40), (40, 95, 125))]


@pytest.mark.parametrize("felt_bgr, body_bgr", SHADED_BALLS)
def test_a_shaded_ball_is_found_by_its_tint(felt_bgr, body_bgr):
    # A ball in a figure's shade: its body barely lighter than the felt, only a thin cap on its top lit. In the light
    # above the felt it is a bright arc over a faint disc, and no light candidate is clear enough (before the tint, no
    # ball was reported). Its chroma lies off the felt-to-grey line over the whole disc, whatever the two colours are.
    frame = drawn_still(ball=None, felt_bgr=felt_bgr)
    cv2.circle(frame, (1200, 500), 20, body_bgr, -1, cv2.LINE_AA)
    cv2.ellipse(frame, (1200, 500), (17, 17), 0, 210, 330, (225, 235, 240), 4, cv2.LINE_AA)
    frame = cv2.GaussianBlur(frame, (5, 5), 1.0)
    finder = StillBallFinder()
    field, candidates = finder.find(frame)
    _, ball = finder.ball(frame)
    assert ball is not None and ball.cue == "tint", candidates[:3]
    assert math.hypot(ball.u - 1200, ball.v - 500) < 4.0, ball


def test_a_tint_pick_needs_a_higher_floor_than_a_light_one():
    # Where the light has no clear ball, a tint candidate is the ball only when it reaches MIN_TINT_SCORE: an end
    # wall's lit beige and a goalkeeper whose green a lamp saturates are tinted and round too, and on the leonhart
    # stills they led with 0.62-0.66 (vision-2026-11-28-stills-4.md). A light candidate of the same score is a pick.
    field = FeltField(np.array([[0, 0], [1000, 0], [1000, 600], [0, 600]], float), (160, 120, 130), 10.0, 0.5)

    def candidate(cue, score, u=500.0):
        return StillCandidate(u, 300.0, 8.0, 20.0, score, 1.0, 0.0, score, cue)

    between = (MIN_SCORE + MIN_TINT_SCORE) / 2
    faint = candidate("light", between - MIN_LEAD - 0.01, u=100.0)  # a rival far away, led by more than MIN_LEAD
    assert still_ball._pick([candidate("tint", between), faint], field) is None
    assert still_ball._pick([candidate("light", between), faint], field).cue == "light"
    clear = candidate("tint", MIN_TINT_SCORE + 0.05)
    assert still_ball._pick([clear, faint], field) is clear


def _lightness_and_tint(frame):
    """A 1080p still's work scale, and how much lighter than the felt and how tinted each work pixel is."""
    scale = still_ball.WORK_WIDTH / 1920
    small = cv2.resize(frame, (still_ball.WORK_WIDTH, round(1080 * scale)), interpolation=cv2.INTER_AREA)
    lab = cv2.cvtColor(small, cv2.COLOR_BGR2Lab)
    field, region = StillBallFinder()._felt(lab, scale)
    r = field.ball_radius_px * scale
    lighter, around = still_ball._lighter_than_felt(small, lab, r)
    team = still_ball._team_colours(lab, region, field.felt_lab, r)
    return scale, lighter, still_ball._tinted(lab, around, lighter, team)


def test_white_light_has_no_tint():
    # The felt's painted lines, a lamp's sheen and white socks mix the felt's colour with grey: no tint, however light.
    # A ball's colour lies off that line. The drawn still has white lines on green felt; a yellow disc is added.
    frame = drawn_still(ball=(1200, 500), ball_bgr=(40, 210, 230))
    cv2.circle(frame, (700, 700), 20, (150, 190, 145), -1, cv2.LINE_AA)  # a half-white, half-felt blur of a sock
    scale, lighter, tinted = _lightness_and_tint(frame)
    line, sock, ball = ((round(y * scale), round(x * scale)) for x, y in ((960, 800), (700, 700), (1200, 500)))
    assert lighter[line] > 50 and tinted[line] < 10, (lighter[line], tinted[line])  # the centre line
    assert lighter[sock] > 20 and tinted[sock] < 10, (lighter[sock], tinted[sock])  # the sock's blur
    assert tinted[ball] > 60, tinted[ball]  # the yellow ball


def test_lit_felt_has_no_tint():
    # A lamp lights the felt unevenly: a lit patch of a saturated felt is the same cloth in more light, its chroma
    # raised with its lightness (a stronger green), not a tint; a yellow ball lit as much is tinted. On renders, such
    # lit patches by the walls were picked as the ball once frames were searched at 1280 px
    # (vision-2026-11-28-stills-4.md).
    frame = drawn_still(ball=(1200, 500), ball_bgr=(40, 210, 230))
    cv2.circle(frame, (700, 700), 20, (81, 175, 67), -1, cv2.LINE_AA)  # the felt's (60, 130, 50) in 1.35x the light
    scale, lighter, tinted = _lightness_and_tint(frame)
    lit, ball = ((round(y * scale), round(x * scale)) for x, y in ((700, 700), (1200, 500)))
    assert lighter[lit] > 20 and tinted[lit] < 10, (lighter[lit], tinted[lit])
    assert tinted[ball] > 60, tinted[ball]


def test_a_team_in_one_colour_is_not_the_ball():
    # Twelve lit heads of the ball's size in a team's yellow, and a white ball: the heads answer the disc filter as
    # well as the ball does, but their colour covers a dozen balls' areas of the field.
    frame = drawn_still(ball=(1200, 500))
    places = [(420 + 100 * k, 420 if k % 2 else 700) for k in range(12)]
    for place in places:
        cv2.circle(frame, place, 20, (40, 210, 230), -1, cv2.LINE_AA)
    field, candidates = StillBallFinder().find(frame)
    assert candidates and math.hypot(candidates[0].u - 1200, candidates[0].v - 500) < 3.0, candidates[:3]
    heads = [c for c in candidates if min(math.hypot(c.u - u, c.v - v) for u, v in places) < 5]
    assert len(heads) >= 10 and min(c.team_balls for c in heads) > TEAM_BALLS, heads


def test_the_felt_is_found_under_a_logo_in_the_middle():
    # An overhead view puts the centre circle, its line and a printed logo in the image's middle: most of the middle
    # tenth is not felt. The felt is the commonest colour around it, not a mix of felt and logo.
    frame = drawn_still(ball=(1200, 500))
    cv2.ellipse(frame, (960, 540), (200, 120), 0, 0, 360, (225, 230, 235), -1)
    finder = StillBallFinder()
    field, ball = finder.ball(frame)
    assert field is not None and 0.4 < field.share < 0.7 and abs(field.ball_radius_px - 20.3) < 2.0, field
    assert ball is not None and math.hypot(ball.u - 1200, ball.v - 500) < 3.0, ball


def test_a_ball_on_the_lit_end_of_the_felt_is_searched():
    # A lamp over one end washes the felt's colour out there: the felt found stops short of the field's end, and the
    # ball lying on that end is within a ball's width of it.
    frame = drawn_still(ball=None)
    cv2.rectangle(frame, (260, 145), (1660, 190), (175, 215, 170), -1)
    cv2.circle(frame, (1200, 170), 20, (235, 235, 235), -1, cv2.LINE_AA)
    field, ball = StillBallFinder().ball(cv2.GaussianBlur(frame, (5, 5), 1.0))
    assert field is not None and field.outline[:, 1].min() > 185, field.outline[:, 1].min()
    assert ball is not None and math.hypot(ball.u - 1200, ball.v - 170) < 3.0, ball


def test_a_felt_is_crossed_by_rods():
    # A stretch of one colour that no rod crosses is no table's felt (leonhart's frame 225: a crowd's grey clothes were
    # the middle's commonest colour, vision-2026-11-28-stills-6.md): the next commonest colour is tried, here the felt.
    frame = drawn_still(ball=(1200, 500))
    cv2.rectangle(frame, (500, 100), (1100, 1000), (110, 95, 120), -1)  # clothing in front of the table's left half
    field, ball = StillBallFinder().ball(frame)
    felt_lab = cv2.cvtColor(np.uint8([[(60, 130, 50)]]), cv2.COLOR_BGR2Lab)[0, 0].astype(float)
    assert field is not None and np.abs(np.array(field.felt_lab[1:]) - felt_lab[1:]).max() < 4, field
    assert ball is not None and math.hypot(ball.u - 1200, ball.v - 500) < 4.0, ball
    # The same felt without its rods: nothing in the frame is a table's felt.
    assert StillBallFinder().find(drawn_still(rods=False)) == (None, [])


def test_no_felt_no_field():
    field, candidates = StillBallFinder().find(np.random.default_rng(1).integers(0, 255, (480, 640, 3), np.uint8))
    assert field is None and candidates == []


# Between the rods (y = +/-0.075, 0.225, 0.375, 0.525), clear of the figures that hang on them.
RENDERED_BALLS = [(0.10, -0.15), (-0.22, 0.30), (0.25, 0.0)]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("colour", ["white", "yellow", "orange"])
def test_a_rendered_ball_is_found_whatever_its_colour(colour):
    from foos_sim.camera.live import LiveCamera, LiveCameraConfig
    from foos_sim.simulation import TableSimulation

    camera = LiveCamera(LiveCameraConfig(rate=60, width=1280, height=720, ball_colour=colour, shadows=True, seed=2))
    finder = StillBallFinder()
    try:
        for x, y in RENDERED_BALLS:
            sim = TableSimulation()
            sim.reset(ball_position=(x, y), ball_velocity=(0.0, 0.0))
            image = camera.capture(sim.data.qpos.copy())
            u, v = camera.camera.project(sim.ball_position()[None, :])[0]
            field, ball = finder.ball(image)
            assert field is not None
            assert ball is not None, (colour, x, y, finder.find(image)[1][:2])
            assert math.hypot(ball.u - u, ball.v - v) < 2 * field.ball_radius_px, (colour, x, y, ball, (u, v))
    finally:
        camera.close()
