"""The drive effects: parsed from the parameter file, applied by TableSimulation on both physics to the former
velocity servos (params/servo_table.yaml; on the jerk-limited drives: test_drive_profiles.py), and the cheap
predictor calibration uses agreeing with the fast physics."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import COMMAND_SIZE, JOINT_NAMES
from foos_core.table_params import SERVO_PARAMS_FILE, load_params
from foos_sim.drive_limits import DriveLimits, Servo, drive_limits_from_effects, predict_positions
from foos_sim.effects import EffectError, resolve
from foos_sim.simulation import TableSimulation

EFFECTS = [
    {"name": "rod_latency", "params": {"delay": 0.03}},
    {"name": "rod_speed_limit", "params": {"slide": 1.5, "rotate": 25.0}},
    {"name": "rod_acceleration_limit", "params": {"slide": 40.0, "rotate": 900.0, "team": "home", "rod": "attack"}},
]
SLIDE = np.array([name.endswith("_slide") for name in JOINT_NAMES])
# Predictor against the fast physics, rods moving freely (no ball near), 0.1 s and 0.2 s ahead, 95th percentile
# over starts and drives. Slides within STOP_ZONE of a travel stop are left out: the stops are soft in MuJoCo
# (a slide driven into one goes up to 9 mm past its travel), the predictor clips at the travel.
SLIDE_TOLERANCE = 0.0005  # m
ROTATE_TOLERANCE = 0.015  # rad (0.9 deg: the rotation drives' force limits are lifted step by step in foos_sim.drives)
STOP_ZONE = 0.015  # m


def table(effects, physics="fast"):
    params = load_params(SERVO_PARAMS_FILE)
    return TableSimulation(params={**params, "effects": effects}, physics=physics)


def test_effects_parse_per_drive_with_narrower_overriding():
    limits = drive_limits_from_effects(EFFECTS + [{"name": "rod_latency", "params": {"delay": 0.05, "team": "away", "rod": "goalie",
                                                                                  "axis": "rotate"}}])
    assert limits.delay[JOINT_NAMES.index("home_goalie_slide")] == 0.03
    assert limits.delay[JOINT_NAMES.index("away_goalie_rotate")] == 0.05
    assert limits.speed[SLIDE].max() == 1.5 and limits.speed[~SLIDE].max() == 25.0
    accel = dict(zip(JOINT_NAMES, limits.acceleration))
    assert accel["home_attack_slide"] == 40.0 and accel["home_attack_rotate"] == 900.0 and np.isinf(accel["away_attack_slide"])
    assert drive_limits_from_effects([{"name": "table_tilt", "params": {"slope_x": 0.0, "slope_y": 0.0}}]) is None


@pytest.mark.parametrize("bad, text", [
    ({"name": "rod_latency", "params": {}}, "needs parameter `delay`"),
    ({"name": "rod_latency", "params": {"delay": -0.1}}, "delay"),
    ({"name": "rod_speed_limit", "params": {"slide": 0}}, "positive"),
    ({"name": "rod_speed_limit", "params": {"team": "home"}}, "`slide` and/or `rotate`"),
    ({"name": "rod_acceleration_limit", "params": {"slide": 10, "rod": "striker"}}, "`rod` must be one of"),
])
def test_bad_drive_effects_are_refused_with_the_parameter_files_other_effects(bad, text):
    with pytest.raises(EffectError, match=text.replace("(", r"\(")):
        resolve({**load_params(), "effects": [bad]})


def test_latency_speed_and_acceleration_act_on_both_physics():
    for physics in ("fast", "reference"):
        sim = table(EFFECTS, physics)
        sim.reset(ball_position=(0.3, 0.0))
        command = np.zeros(COMMAND_SIZE)
        command[6], command[7] = 3.0, 40.0  # attack slide and rotation, full speed
        sim.set_command("home", command)
        sim.advance(0.028)
        assert np.allclose(sim.joint_velocities()[6:8], 0.0, atol=1e-6), physics  # dead time
        sim.advance(0.032)  # 30 ms after the delay: the attack slide ramps at 40 m/s^2
        assert 1.0 < sim.joint_velocities()[6] < 1.3, (physics, sim.joint_velocities()[6])
        sim.advance(0.2)
        assert sim.joint_velocities()[7] == pytest.approx(25.0, abs=0.3), physics  # speed limit
        sim.set_command("away", command)
        sim.advance(0.06)
        assert sim.joint_velocities()[COMMAND_SIZE + 6] == pytest.approx(1.5, abs=0.05), physics  # no ramp away


def test_no_drive_effect_keeps_the_nominal_drives():
    sim = table([])
    assert sim.drive_limits() is None
    sim.set_command("home", [0, 0, 0, 0, 0, 0, 3.0, 0])
    sim.advance(0.03)
    assert sim.joint_velocities()[6] == pytest.approx(3.0, abs=0.02)


def test_predictor_agrees_with_the_fast_physics():
    rng = np.random.default_rng(4)
    sim = table(EFFECTS)
    sim.reset(ball_position=(0.3, 0.58))  # the ball parked in a corner, away from the figures
    limits, servo = sim.drive_limits(), sim.drive_servo()
    travel = np.array([0.12, np.inf, 0.19, np.inf, 0.08, np.inf, 0.135, np.inf])
    command_t, commands, states = [], [], []
    scale = np.where(SLIDE[:COMMAND_SIZE], 0.4, 1.0)  # slides mostly clear of their stops
    for k in range(500):  # 10 s of random commands at 50 Hz, changes and reversals every 0.1 s
        if k % 5 == 0:
            current = rng.uniform(-1, 1, COMMAND_SIZE) * sim.command_limits * scale
        command_t.append(sim.time)
        commands.append(current.copy())
        sim.set_command("home", current)
        states.append((sim.time, sim.joint_positions()[:COMMAND_SIZE], sim.joint_velocities()[:COMMAND_SIZE]))
        sim.advance(0.02)
    command_t, commands = np.array(command_t), np.array(commands)
    t = np.array([s[0] for s in states])
    position = np.array([s[1] for s in states])
    velocity = np.array([s[2] for s in states])
    starts = np.arange(10, 480, 2)
    home = limits.team("home")
    servo_home = Servo(servo.inertia[:COMMAND_SIZE], servo.gain[:COMMAND_SIZE], servo.force_limit[:COMMAND_SIZE])
    predicted = predict_positions(t[starts], position[starts], velocity[starts], command_t, commands, home, servo_home,
                                  sim.command_limits, (0.1, 0.2), travel)
    for h, steps in enumerate((5, 10)):
        error = np.abs(predicted[:, h] - position[starts + steps])
        free = np.ones(len(starts), dtype=bool)[:, None] & (np.abs(position[starts + steps][:, 0::2]) < travel[0::2] - STOP_ZONE)
        for k in range(steps + 1):  # nowhere near a stop on the way
            free &= np.abs(position[starts + k][:, 0::2]) < travel[0::2] - STOP_ZONE
        slide = error[:, 0::2][free]
        rotate = error[:, 1::2]
        assert slide.size > 100
        assert np.percentile(slide, 95) < SLIDE_TOLERANCE and np.percentile(rotate, 95) < ROTATE_TOLERANCE
    assert isinstance(home, DriveLimits)
