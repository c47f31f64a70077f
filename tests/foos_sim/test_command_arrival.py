"""A rod command acts at the time it arrives (TableSimulation.set_command's `at`), within a physics step, on both
drive kinds and both physics: a real drive acts on its command within its own servo cycle, not at the next 2 ms step."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import COMMAND_SIZE, JOINT_NAMES
from foos_core.table_params import ROBOT_PARAMS_FILE, SERVO_PARAMS_FILE
from foos_sim import scurve
from foos_sim.drive_profiles import profile_limits
from foos_sim.simulation import CommandError, TableSimulation

ROTATE = JOINT_NAMES.index("home_attack_rotate")
ARRIVAL = 0.0503  # s: 0.3 ms into a fast step (2 ms) and 0.3 ms past the reference's last step (50 us) before it
END = 0.15


def _command(rotate: float) -> np.ndarray:
    command = np.zeros(COMMAND_SIZE)
    command[ROTATE] = rotate
    return command


def _rotation_after_switch(params_file, physics: str, first: float, second: float, arrival: float) -> tuple[float, float]:
    """The home attack's angle at END (and the time then) after `first` from rest and `second` arriving at `arrival`."""
    sim = TableSimulation(params_file, physics=physics)
    sim.reset(ball_position=(0.3, 0.58))
    sim.set_command("home", _command(first))
    sim.advance(0.05)
    sim.set_command("home", _command(second), at=arrival)
    sim.advance(END - sim.time)
    return float(sim.joint_positions()[ROTATE]), sim.time


@pytest.mark.parametrize("physics", ["fast", "reference"])
def test_a_command_arriving_within_a_step_moves_the_s_curve_drive_as_the_exact_piecewise_command(physics):
    """The robot table: 100 rad/s from rest, then -200 rad/s arriving 0.3 ms into a step. The rod ends where the
    S-curve switched at that instant puts it (within 2 mrad); at the next step's start (2 ms fast, 50 us reference)
    it would be 0.6 rad (fast) or 18 mrad (reference) off."""
    angle, end = _rotation_after_switch(ROBOT_PARAMS_FILE, physics, 100.0, -200.0, ARRIVAL)
    limits = profile_limits(TableSimulation(ROBOT_PARAMS_FILE, physics=physics).params)
    accel, jerk = limits.acceleration[ROTATE], limits.jerk[ROTATE]

    def exact(switch: float) -> float:
        v, a, before = scurve.evaluate(scurve.plan(0.0, 0.0, 100.0, accel, jerk), switch)
        _, _, after = scurve.evaluate(scurve.plan(v, a, -200.0, accel, jerk), end - switch)
        return float(before + after)

    step = 0.002 if physics == "fast" else 5e-5
    next_step = (np.floor(ARRIVAL / step + 1e-6) + 1) * step
    assert abs(exact(next_step) - exact(ARRIVAL)) > 0.015  # what the test tells apart
    assert angle == pytest.approx(exact(ARRIVAL), abs=0.002)


@pytest.mark.parametrize("physics", ["fast", "reference"])
def test_a_command_arriving_within_a_step_moves_the_velocity_servo_as_the_exact_piecewise_command(physics):
    """The former servos: 10 rad/s, then -10 rad/s arriving 0.3 ms into a step or 3.7 ms later, on a step's start.
    The rod ends 20 rad/s x 3.7 ms = 74 mrad apart (acting at the steps' starts instead: 20 x 4 ms, 80 mrad fast)."""
    early, _ = _rotation_after_switch(SERVO_PARAMS_FILE, physics, 10.0, -10.0, ARRIVAL)
    late, _ = _rotation_after_switch(SERVO_PARAMS_FILE, physics, 10.0, -10.0, 0.054)
    assert late - early == pytest.approx(20.0 * (0.054 - ARRIVAL), abs=0.001)


def test_a_teams_commands_act_in_the_order_they_arrive():
    sim = TableSimulation(ROBOT_PARAMS_FILE)
    sim.reset(ball_position=(0.3, 0.58))
    sim.set_command("home", _command(50.0), at=0.0071)
    sim.set_command("home", _command(-50.0), at=0.0033)  # sent later, arrives first
    sim.advance(0.005)
    assert sim.joint_velocities()[ROTATE] < 0.0
    sim.advance(0.2)
    assert sim.joint_velocities()[ROTATE] == pytest.approx(50.0, abs=0.1)


def test_a_command_cannot_arrive_before_now_or_at_no_time():
    sim = TableSimulation(ROBOT_PARAMS_FILE)
    sim.advance(0.01)
    with pytest.raises(CommandError, match="no earlier than now"):
        sim.set_command("home", _command(1.0), at=0.005)
    with pytest.raises(CommandError, match="finite time"):
        sim.set_command("home", _command(1.0), at=float("nan"))
