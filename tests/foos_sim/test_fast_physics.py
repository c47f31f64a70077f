"""The fast physics against the 20 kHz reference: the same balls on both agree; the physics switch; advance()."""
import copy
import math
import subprocess

import numpy as np
import pytest

import foos_sim
from foos_core.table_params import REFERENCE_PARAMS_FILE, SERVO_PARAMS_FILE, load_params
from foos_sim.model_builder import PhysicsError
from foos_sim.simulation import TableSimulation

from ..user_env import workspace_env
from .helpers import figure_bounce, launch, rods_up_but, sample_period, wall_bounce
from .test_physics import fitted_deceleration, full_speed_kick, speed_history

NOMINAL = load_params()
# Every effect of the contract's vocabulary that changes the ball's physics, one wall with its own restitution.
CALIBRATED_EFFECTS = [
    {"name": "table_tilt", "params": {"slope_x": 0.003, "slope_y": -0.004}},
    {"name": "rolling_resistance", "params": {"deceleration": 0.2}},
    {"name": "viscous_damping", "params": {"rate": 0.1}},
    {"name": "air_drag", "params": {"coefficient": 0.05}},
    {"name": "surface_dent", "params": {"x": 0.1, "y": 0.2, "radius": 0.08, "depth": 0.002}},
    {"name": "wall_restitution", "params": {"coefficient": 0.6}},
    {"name": "wall_restitution", "params": {"coefficient": 0.45, "wall": "wall_side_pos_x"}},
]


@pytest.fixture(scope="module")
def both():
    return {physics: TableSimulation(physics=physics) for physics in ("fast", "reference")}


@pytest.fixture(scope="module")
def servo_both():
    """The former 40 rad/s velocity servos (params/servo_table.yaml) on both physics."""
    return {physics: TableSimulation(SERVO_PARAMS_FILE, physics=physics) for physics in ("fast", "reference")}


@pytest.fixture(scope="module")
def calibrated_both():
    params = copy.deepcopy(NOMINAL)
    params["effects"] = CALIBRATED_EFFECTS
    return {physics: TableSimulation(params=params, physics=physics) for physics in ("fast", "reference")}


def track(sim, start, velocity, seconds, period=0.01):
    launch(sim, start, velocity)
    positions = []
    for _ in range(round(seconds / period)):
        sim.advance(period)
        positions.append(sim.ball_position()[:2].copy())
    return np.array(positions)


@pytest.mark.parametrize("start, velocity", [((-0.25, -0.45), (0.3, 1.5)), ((0.2, 0.4), (-0.8, -2.5)), ((0.0, 0.0), (0.2, 0.4))])
def test_the_same_rolls_agree(both, start, velocity):
    """Rolls clear of walls and figures: the same path within 3 mm over 0.6 s, the same deceleration within 5 %."""
    paths = {physics: track(sim, start, velocity, 0.6) for physics, sim in both.items()}
    assert np.max(np.linalg.norm(paths["fast"] - paths["reference"], axis=1)) < 0.003
    decelerations = {}
    for physics, sim in both.items():
        launch(sim, start, velocity)
        ts, speeds, _ = speed_history(sim, 1.5)
        decelerations[physics] = fitted_deceleration(ts, speeds)
    assert decelerations["fast"] == pytest.approx(decelerations["reference"], rel=0.05)


@pytest.mark.parametrize("speed", [0.5, 2.0, 5.0])
@pytest.mark.parametrize("start, direction, normal", [((0.2, 0.1), (1, 0), (-1, 0)), ((-0.22, -0.3), (0, -1), (0, 1))])
def test_the_same_wall_bounces_agree(both, speed, start, direction, normal):
    velocity = speed * np.asarray(direction, dtype=float)
    e = {physics: wall_bounce(sim, start, velocity, normal) for physics, sim in both.items()}
    assert e["fast"] == pytest.approx(e["reference"], abs=0.05)


def test_a_wall_bounce_leaves_the_ball_where_the_reference_does(both):
    """Into a side wall at 3 m/s, off it with its spin: the same velocity after (normal within 0.05 of the
    speed in, along the wall and upward within 0.03 m/s) and the same place 0.2 s after the launch."""
    after = {}
    for physics, sim in both.items():
        launch(sim, (0.1, 0.0), (3.0, 0.5))
        sim.advance(0.2)
        after[physics] = (sim.ball_position().copy(), sim.ball_velocity().copy())
    (p_fast, v_fast), (p_ref, v_ref) = after["fast"], after["reference"]
    assert abs(v_fast[0] - v_ref[0]) < 0.05 * 3.0
    assert abs(v_fast[1] - v_ref[1]) < 0.03
    assert np.linalg.norm(p_fast[:2] - p_ref[:2]) < 0.01


@pytest.mark.parametrize("speed", [0.5, 2.0, 5.0])
@pytest.mark.parametrize("rod, figure_x", [("home_midfield", 0.0), ("home_goalie", 0.0), ("home_attack", 0.185)])
def test_the_same_figure_bounces_agree(both, speed, rod, figure_x):
    """Off a figure at rest on its nominal rod (which recoils, held by its drive), the ball comes back at the
    same share of its speed within 0.05."""
    e = {physics: figure_bounce(sim, rod, speed, figure_x) for physics, sim in both.items()}
    assert e["fast"] == pytest.approx(e["reference"], abs=0.05)


@pytest.mark.parametrize("rod, drawn_back, ball_offset", [("attack", -0.6, 0.025), ("attack", -1.0, 0.03), ("midfield", -0.6, 0.025),
                                                           ("goalie", -0.8, 0.028)])
def test_the_same_kicks_on_the_former_servos_agree(servo_both, rod, drawn_back, ball_offset):
    """Full-speed kicks of a resting ball on the 40 rad/s servos: 3-4.5 m/s on both, within 5 % of each other
    (the jerk-limited drives' kicks: test_kicks.py)."""
    peaks = {physics: full_speed_kick(sim, drawn_back, ball_offset, rod)[0] for physics, sim in servo_both.items()}
    assert 3.0 < peaks["fast"] < 4.5 and 3.0 < peaks["reference"] < 4.5
    assert peaks["fast"] == pytest.approx(peaks["reference"], rel=0.05)


@pytest.mark.parametrize("start", [(0.1, -0.2), (0.05, -0.2), (0.14, -0.1)])
def test_a_calibrated_table_agrees_on_both(calibrated_both, start):
    """Tilt, rolling resistance, viscous damping, air drag and a dent (the fast physics pushes the ball
    down its slopes, the reference has it in its height field): the same path across the dent within
    2 mm over 0.6 s, where the dent itself moves the ball by 1-5 mm."""
    paths = {physics: track(sim, start, (0.0, 1.0), 0.6) for physics, sim in calibrated_both.items()}
    assert np.max(np.linalg.norm(paths["fast"] - paths["reference"], axis=1)) < 0.002


@pytest.mark.parametrize("start, direction, normal, coefficient", [
    ((0.2, 0.1), (1, 0), (-1, 0), 0.45),    # the wall with its own restitution
    ((-0.2, -0.3), (-1, 0), (1, 0), 0.6),   # every other wall
    ((0.22, 0.3), (0, 1), (0, -1), 0.6),
])
@pytest.mark.parametrize("physics", ["fast", "reference"])
def test_a_calibrated_wall_restitution_holds_per_wall(calibrated_both, physics, start, direction, normal, coefficient):
    for speed in (0.7, 3.0):
        e = wall_bounce(calibrated_both[physics], start, speed * np.asarray(direction, dtype=float), normal)
        assert e == pytest.approx(coefficient, abs=0.05)


def test_the_parameter_file_names_the_physics(tmp_path):
    # The regulation table runs the fast physics; the shipped reference_table.yaml names the 20 kHz reference.
    sim = TableSimulation()
    assert sim.physics == "fast" and sim.timestep == pytest.approx(0.002)
    reference = TableSimulation(REFERENCE_PARAMS_FILE)
    assert reference.physics == "reference" and reference.timestep == pytest.approx(5e-5)
    assert TableSimulation(physics="reference").physics == "reference"
    assert TableSimulation(REFERENCE_PARAMS_FILE, physics="fast").physics == "fast"
    # The bare model is the reference unless asked: stepped by mj_step alone, only its springs bounce.
    assert foos_sim.load_model().opt.timestep == pytest.approx(5e-5)
    assert foos_sim.load_model(physics="fast").opt.timestep == pytest.approx(0.002)
    for text, message in (("physics: warp", "solver.physics must be one of fast, reference"),
                          ("physics: fast\n  fast: {timestep: -1}", "solver.fast.timestep")):
        bad = tmp_path / "bad.yaml"
        bad.write_text(f"base: regulation_table\nsolver:\n  {text}\n")
        with pytest.raises(PhysicsError, match=message):
            TableSimulation(bad)


def test_sim_node_refuses_an_unknown_physics_in_one_line(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("base: regulation_table\nsolver:\n  physics: warp\n")
    result = subprocess.run(["ros2", "run", "foos_sim", "sim_node", "--ros-args", "-p", f"params_file:={bad}"],
                            env=workspace_env(domain=18), capture_output=True, text=True, timeout=60)
    assert result.returncode != 0
    lines = [line for line in result.stderr.splitlines() if "solver.physics" in line]
    assert len(lines) == 1 and "fast, reference" in lines[0]


def test_advance_follows_the_time_asked_within_half_a_step(nominal_sim):
    nominal_sim.reset()
    rng = np.random.default_rng(3)
    asked = 0.0
    for seconds in rng.uniform(0.0, 0.011, 300):
        nominal_sim.advance(seconds)
        asked += seconds
        assert abs(nominal_sim.time - asked) <= 0.5 * nominal_sim.timestep + 1e-9
    for bad in (-0.01, math.nan, math.inf):
        with pytest.raises(ValueError, match="finite number of seconds"):
            nominal_sim.advance(bad)


def test_a_goal_stays_scored_through_an_advance(nominal_sim):
    launch(nominal_sim, (0.0, 0.45), (0.0, 4.0))
    assert nominal_sim.advance(0.02) is None
    assert nominal_sim.advance(0.2) == "home"
    assert nominal_sim.advance(0.5) == "home"  # latched, even after the ball has bounced out of the pocket


def test_a_fast_shot_into_a_figure_does_not_pass_through(nominal_sim):
    """At 15 m/s (the paper's serve) the ball travels 30 mm a step, more than a foot is thick (22 mm)."""
    for speed in (8.0, 12.0, 15.0):
        launch(nominal_sim, (0.0, -0.3), (0.0, speed), rods=rods_up_but("home_midfield"))
        period = sample_period(nominal_sim)
        for _ in range(round(0.05 / period)):
            nominal_sim.advance(period)
            assert nominal_sim.ball_position()[1] < -0.075 - 0.011 - nominal_sim.ball_radius + 0.002
        assert nominal_sim.figure_touches()[0] == 1  # one hit, and back: the ball may fly on into other figures
