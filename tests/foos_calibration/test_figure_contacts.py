"""Figure contacts cut the ball track in games (foos_calibration.figure_contacts and tracks.analyse(figures=)).

The games are played by foos_calibration.games' players on the fast physics; this module steps them itself
so that it can keep the simulator's own record of every figure touch, the truth the cuts are checked on.
"""
from __future__ import annotations

import numpy as np
import pytest

from foos_calibration import games
from foos_calibration import generate as gen
from foos_calibration.figure_contacts import (
    FigureModel,
    JointTrack,
    PosedFigures,
    RodLines,
    _rotation_x,
    _spread,
    for_game,
)
from foos_calibration.fitting import SegmentBatch, dent_search, fit, fit_states
from foos_calibration.select import MIN_EVIDENCE, free_indices
from foos_calibration.surrogate import EFFECT_PARAMS
from foos_calibration.tracks import analyse, on_field, split_tracks
from foos_core.names import COMMAND_SIZE, JOINT_NAMES, TEAMS
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import DEFAULT_PARAMS_FILE, load_params
from foos_sim import TableSimulation

TILT = {"name": "table_tilt", "params": {"slope_x": 0.006, "slope_y": -0.004}}


def play_with_truth(duration: float, seed: int, effects=()) -> dict:
    """A game by games.Player on the fast table (table effects through the parameters), camera at 120 fps with
    1.5 mm noise and 5 % dropouts, encoders at 250 Hz, and the simulator's touch flag and the ball's height at every
    physics step."""
    rng = np.random.default_rng(seed)
    params = {**load_params(DEFAULT_PARAMS_FILE), "effects": list(effects)}
    sim = TableSimulation(params=params)
    players = [games.Player(team, params, games.player_limits(sim.command_limits), rng, 0.35) for team in TEAMS]
    sim.reset()
    games._serve(sim, rng)
    per_control = round(games.CONTROL_PERIOD / sim.timestep)
    t, ball, joints, touched = [], [], [], []
    rest_since = None
    for k in range(int(round(duration / sim.timestep))):
        if k % per_control == 0:
            b, q = sim.ball_position(), sim.joint_positions()
            for i, (team, player) in enumerate(zip(TEAMS, players)):
                sim.set_command(team, player.command(sim.time, b, q[i * COMMAND_SIZE:(i + 1) * COMMAND_SIZE]))
        goal = sim.step(1)
        t.append(sim.time)
        ball.append(sim.ball_position())
        joints.append(sim.joint_positions())
        touched.append(any(sim.figure_contacts()))
        slow = np.hypot(*sim.ball_velocity()[:2]) < games.REST_SPEED
        rest_since = (rest_since if rest_since is not None else sim.time) if slow else None
        if goal or not sim.ball_on_field() or (rest_since is not None and sim.time - rest_since > games.REST_TIME):
            games._serve(sim, rng)
            rest_since = None
    t, ball, joints = np.array(t), np.array(ball), np.array(joints)
    frames = np.arange(t[0], t[-1], 1 / 120)
    index = np.searchsorted(t, frames)
    seen = rng.random(len(frames)) >= 0.05
    xy = ball[index[seen], :2] + rng.normal(0, 0.0015, size=(seen.sum(), 2))
    encoder = np.arange(7, len(t), 8)  # 250 Hz
    return {"t": frames[seen], "xy": xy, "joint_t": t[encoder], "joint_q": joints[encoder], "truth_t": t,
            "touched": np.array(touched), "height": ball[:, 2], "params": params}


def runs(mask: np.ndarray) -> list[tuple[int, int]]:
    edges = np.diff(np.concatenate([[0], mask.astype(int), [0]]))
    return list(zip(np.flatnonzero(edges == 1), np.flatnonzero(edges == -1)))


@pytest.fixture(scope="module")
def game():
    return play_with_truth(30.0, seed=4, effects=[TILT])


@pytest.fixture(scope="module")
def posed(game):
    return for_game(game["params"], JointTrack(game["joint_t"], game["joint_q"]))


def touches_in(segments, game) -> int:
    when = game["truth_t"][game["touched"]]
    return sum(bool(np.any((when >= s.t[0]) & (when <= s.t[-1]))) for s in segments)


def test_a_figure_pose_puts_a_touching_ball_at_zero_gap():
    params = load_params()
    figures = FigureModel(params)
    y = params["rods"]["layout"]["home_attack"]["y"]
    foot_half_thickness = params["figure"]["foot_size"][1] / 2
    radius = params["ball"]["radius"]
    q = np.zeros((3, len(JOINT_NAMES)))
    q[1, JOINT_NAMES.index("home_attack_slide")] = 0.05  # slid 5 cm toward +x: its middle figure follows
    q[2, JOINT_NAMES.index("home_attack_rotate")] = np.pi / 2  # lifted: figures horizontal, clear of the ball
    xy = np.array([[0.0, y + foot_half_thickness + radius]] * 2 + [[0.0, y]])
    xy[1, 0] = 0.05
    gap = figures.distance(xy, q)
    assert abs(gap[0]) < 1e-9 and abs(gap[1]) < 1e-9
    assert gap[2] > 0.01
    assert 0.05 < figures.reach_y < 0.09  # a swinging figure reaches this far from its rod line


def test_posed_gaps_are_the_einsum_formulas_bits():
    """FigureModel.poses and distance sum their 3-term products without np.einsum (robot-cpu-6): the same bits."""
    figures = FigureModel(load_params())
    rng = np.random.default_rng(4)
    q = np.zeros((4000, len(JOINT_NAMES)))
    q[:, 0::2], q[:, 1::2] = rng.uniform(-0.12, 0.12, (4000, 8)), rng.uniform(-20.0, 20.0, (4000, 8))
    xy = np.stack([rng.uniform(-0.6, 0.6, 4000), rng.uniform(-0.35, 0.35, 4000)], axis=1)
    g = figures.geoms
    turn = _rotation_x(q[:, g.rotate])
    centre = g.axis_origin[None] + np.einsum("ngij,gj->ngi", turn, g.offset)
    centre[..., 0] += q[:, g.slide]
    mat = np.einsum("ngij,gjk->ngik", turn, g.mat)
    ball = np.concatenate([xy, np.full((len(xy), 1), figures.ball_radius)], axis=1)
    local = np.einsum("ngji,ngj->ngi", mat, ball[:, None, :] - centre)
    outside = np.abs(local) - g.half[None]
    gap = np.linalg.norm(np.maximum(outside, 0.0), axis=-1) + np.minimum(outside.max(axis=-1), 0.0)
    posed_centre, posed_mat = figures.poses(q)
    assert np.array_equal(posed_centre.view(np.int64), centre.view(np.int64))
    assert np.array_equal(posed_mat.view(np.int64), mat.view(np.int64))
    assert np.array_equal(figures.distance(xy, q).view(np.int64), (gap.min(axis=1) - figures.ball_radius).view(np.int64))


def test_contacts_with_joint_states_are_found_and_no_segment_runs_through_one(game, posed):
    geometry = TableGeometry.from_params(game["params"])
    true_runs = [(game["truth_t"][a], game["truth_t"][b - 1]) for a, b in runs(game["touched"])]
    found, total, cut_runs, false_cuts = 0, 0, 0, 0
    tolerance = 2.5 / 120
    for tt, pp in split_tracks(game["t"], game["xy"]):
        inside = on_field(geometry, pp)
        if not inside.all():  # a goal: the track ends there, as in tracks.flights_of_track
            tt, pp = tt[: int(np.argmin(inside))], pp[: int(np.argmin(inside))]
        if len(tt) < 2:
            continue
        cuts = [(tt[a], tt[b - 1]) for a, b in runs(posed.contact_frames(tt, pp))]
        mine = [r for r in true_runs if tt[0] <= r[0] and r[1] <= tt[-1]]
        total += len(mine)
        found += sum(any(a - tolerance <= r0 <= b + tolerance for a, b in cuts) for r0, _ in mine)
        cut_runs += len(cuts)
        false_cuts += sum(not any(r1 >= a - tolerance and r0 <= b + tolerance for r0, r1 in mine) for a, b in cuts)
    assert total > 40, "the game should have plenty of figure touches"
    assert found >= 0.95 * total, f"found {found} of {total} figure touches"
    # Near misses (a ball rolling past a hanging figure within 5 mm) are cut too: data lost, none corrupted.
    assert false_cuts <= 0.45 * cut_runs, f"{false_cuts} of {cut_runs} cuts had no touch near them"
    measured = analyse(game["t"], game["xy"], geometry, figures=posed)
    plain = analyse(game["t"], game["xy"], geometry)
    assert touches_in(measured.segments, game) == 0
    assert touches_in(plain.segments, game) > 0  # without the figures the segments run through kicks
    assert len(measured.segments) >= 8 and any(s.slide for s in measured.segments)


def test_a_game_with_a_hidden_tilt_gives_segments_that_find_it(game, posed):
    geometry = TableGeometry.from_params(game["params"])
    measured = analyse(game["t"], game["xy"], geometry, figures=posed)
    batch = SegmentBatch(measured.segments)
    theta0 = gen.surrogate_theta(gen.HiddenEffects())
    result = fit(batch, free_indices(["table_tilt"]), theta0)
    slope_x, slope_y = (result.theta[i] for i in EFFECT_PARAMS["table_tilt"])
    truth = np.array([TILT["params"]["slope_x"], TILT["params"]["slope_y"]])
    assert np.hypot(slope_x - truth[0], slope_y - truth[1]) < 0.2 * np.hypot(*truth), (slope_x, slope_y)


def test_without_joint_states_rod_line_changes_cut_the_kicks(game, posed):
    geometry = TableGeometry.from_params(game["params"])
    lines = for_game(game["params"], None)
    assert isinstance(lines, RodLines) and isinstance(posed, PosedFigures)
    plain = analyse(game["t"], game["xy"], geometry)
    cut = analyse(game["t"], game["xy"], geometry, figures=lines)
    assert touches_in(cut.segments, game) / len(cut.segments) < 0.6 * touches_in(plain.segments, game) / len(plain.segments)


def test_free_rolls_keep_their_segments_exactly():
    params = load_params()
    geometry = TableGeometry.from_params(params)
    rec = gen.generate([TILT], 30.0, seed=5)
    t, xy = rec.t, rec.position[:, :2]
    lifted = np.zeros((2, len(JOINT_NAMES)))
    lifted[:, 1::2] = np.pi / 2  # rods parked horizontal, as for a free-roll recording
    parked = JointTrack(np.array([t[0] - 1, t[-1] + 1]), lifted)
    plain = analyse(t, xy, geometry)
    for figures in (for_game(params, None), for_game(params, parked)):
        other = analyse(t, xy, geometry, figures=figures)
        assert len(other.segments) == len(plain.segments) and len(other.bounces) == len(plain.bounces)
        for a, b in zip(plain.segments, other.segments):
            assert np.array_equal(a.t, b.t) and np.array_equal(a.xy, b.xy) and a.slide == b.slide
        assert other.noise == plain.noise


def test_a_stretch_shorter_than_the_window_keeps_its_length():
    """A stretch between two figure contacts can be a few frames long (bench_calibration --games crashed on one)."""
    short = np.zeros(5, dtype=bool)
    short[2] = True
    assert _spread(short, 6).tolist() == [True] * 5
    long = np.zeros(30)
    long[[3, 17]] = 1
    assert np.array_equal(_spread(long, 6), np.convolve(long, np.ones(13), mode="same") > 0)


def test_a_sudden_turn_the_posed_figures_cannot_explain_is_still_cut():
    """A hard kick sends the ball flying (8 cm high on the fast physics) into figures raised above the field, where the
    gaps of a ball resting on the field see nothing. Here the rods are parked horizontal, far above a rolling ball,
    and the ball turns back 45 mm from a rod line: with the joint states it is cut there as without them. Left in a
    rolling segment, such a touch bent it, and a small deep dent at the rod line absorbed the bend (issue 17: false
    5.9 mm dents on nominal games). A roll that does not turn is not cut."""
    params = load_params()
    rng = np.random.default_rng(3)
    t = np.arange(0.0, 0.6, 1 / 120)
    turn = 0.3
    rod_y = params["rods"]["layout"]["home_midfield"]["y"]
    y = rod_y - 0.045 - np.where(t < turn, 1.2 * (turn - t), 0.8 * (t - turn))
    x = 0.2 + 0.3 * t
    xy = np.stack([x, y], axis=1) + rng.normal(0.0, 0.0015, (len(t), 2))
    lifted = np.zeros((2, len(JOINT_NAMES)))
    lifted[:, 1::2] = np.pi / 2
    posed = for_game(params, JointTrack(np.array([t[0] - 1, t[-1] + 1]), lifted))
    assert posed.figures.distance(xy, lifted[:1].repeat(len(t), axis=0)).min() > 0.02  # the poses see nothing near
    cut = posed.contact_frames(t, xy)
    assert cut[np.abs(t - turn) < 1.5 / 120].all(), t[cut]
    assert not cut[np.abs(t - turn) > 0.1].any(), t[cut]
    straight = np.stack([x, rod_y - 0.045 - 1.2 * (turn - t)], axis=1) + rng.normal(0.0, 0.0015, (len(t), 2))
    assert not posed.contact_frames(t, straight).any()


def test_a_nominal_game_leaves_no_touch_in_its_segments_for_a_dent_to_absorb():
    """Issue 17: on nominal games `calibrate` fitted small deep dents (5.9-6 mm, the depth limit) within a figure's
    reach of a rod line. Each rested on one or two rolling segments with a figure touch left in them, most often a ball in
    the air (kicked 8 cm high) meeting a raised figure, or a second touch a few frames after the first, by a side
    wall or a foot. This game (60 s, seed 5) had such a touch in a segment before the cut caught them, and the dent
    search found 148 noise variances there (a 6 mm bump of radius 4 cm, 45 mm from a rod line); now none, and
    under 6. A game is chaotic across CPUs, so elsewhere the touches differ, but cuts that miss none leave no dent."""
    game = play_with_truth(60.0, seed=5)
    radius = game["params"]["ball"]["radius"]
    assert np.sum(game["touched"] & (game["height"] > radius + 0.005)) > 20, "the game should kick the ball into the air"
    geometry = TableGeometry.from_params(game["params"])
    measured = analyse(game["t"], game["xy"], geometry, figures=for_game(game["params"], JointTrack(game["joint_t"], game["joint_q"])))
    assert len(measured.segments) >= 20
    assert touches_in(measured.segments, game) == 0
    batch = SegmentBatch(measured.segments)
    _, gain = dent_search(batch, fit_states(batch, gen.surrogate_theta(gen.HiddenEffects())), geometry)
    assert gain / measured.noise**2 < MIN_EVIDENCE, gain / measured.noise**2
