"""The drive fit's resolution on the robot table's jerk-limited drives (params/robot_table.yaml, 314 rad/s rotations):
values between the fine grids' points.

There a rotation turning at 300 rad/s is 0.22 rad off 0.25 s later for 0.75 ms of latency, and 0.4 rad for 3 % of
acceleration limit, against 3 mrad of encoder noise; the fine grids' steps are 1.5 ms and 8 %. On the styled bench
(docs/measurements/calibration-2026-11-28-robot-bench-5.md, trial 6) a 716 rad/s^2 limit was fitted at the grid point
693.3 and the calibrated rotations stayed 25.6 deg off 0.25 s ahead. On these 30 s games (seed 11), before the
parabola between grid points (rods._between_grid_points): 693.3 rad/s^2 and 26.9 deg; 46.5 ms for 47.3 and 7.5 deg.
After: 711.9 rad/s^2 and 4.9 deg; 47.15 ms and 1.5 deg.
"""
from __future__ import annotations

from foos_calibration.game_data import drive_model
from foos_calibration.games import GameOptions, play
from foos_calibration.rods import DriveData, identify
from foos_core.names import TEAMS
from foos_core.table_params import ROBOT_PARAMS_FILE, load_params


def identified_on_the_robot_table(effects: list[dict], seed: int = 11):
    params = load_params(ROBOT_PARAMS_FILE)
    recording = play(effects, GameOptions(duration=30.0, seed=seed), params=params)
    data = DriveData(recording.joint_t, recording.joint_position, recording.joint_velocity,
                     {team: recording.command_t for team in TEAMS}, recording.commands)
    return identify(data, drive_model(params))


def test_an_acceleration_limit_between_grid_points_is_fitted_between_them():
    result = identified_on_the_robot_table([{"name": "rod_acceleration_limit", "params": {"rotate": 716.0}}])
    assert [e["name"] for e in result.effects] == ["rod_acceleration_limit"], result.effects
    fitted = result.effects[0]["params"]["rotate"]
    assert abs(fitted - 716.0) <= 0.015 * 716.0, fitted  # the grid point beside it, 693.3, is 3.2 % off
    assert result.block["calibrated"]["rotate_median_error_deg_0_25s"] < 10.0, result.block["calibrated"]


def test_a_latency_between_grid_points_is_fitted_between_them():
    result = identified_on_the_robot_table([{"name": "rod_latency", "params": {"delay": 0.0473}}])
    assert [e["name"] for e in result.effects] == ["rod_latency"], result.effects
    fitted = result.effects[0]["params"]["delay"]
    assert abs(fitted - 0.0473) <= 0.0005, fitted  # the grid points beside it: 46.5 and 48.0 ms
    assert result.block["calibrated"]["rotate_median_error_deg_0_25s"] < 4.0, result.block["calibrated"]
