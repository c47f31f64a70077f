"""foos_core: the contract's names, the table geometry read from the parameter file, joint order and stamps."""
from __future__ import annotations

import numpy as np
import pytest
import yaml

from foos_core import names
from foos_core.joints import MissingJointsError, joint_order, take_joints
from foos_core.stamps import seconds_to_stamp, stamp_to_seconds
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import DEFAULT_PARAMS_FILE, load_params
from foos_sim import load_model


def test_joint_names_follow_the_contract():
    assert len(names.JOINT_NAMES) == 16 and names.COMMAND_SIZE == 8
    assert names.JOINT_NAMES[:2] == ("home_goalie_slide", "home_goalie_rotate")
    assert names.JOINT_NAMES[8:] == names.team_joint_names("away")
    assert names.command_topic("away") == "/away/rods/command"


def test_every_figure_geom_of_the_model_is_named_by_the_convention():
    model = load_model()
    geoms = [model.geom(i).name for i in range(model.ngeom)]
    figures = [g for g in geoms if names.is_figure_geom(g)]
    # 11 figures a team, a body and a foot each
    assert len(figures) == 2 * 11 * len(names.FIGURE_PARTS)
    assert {names.figure_team(g) for g in figures} == set(names.TEAMS)
    assert names.figure_geom_name("home", "attack", 0, "foot") in figures
    assert all(names.figure_team(g) is None for g in geoms if g not in figures)


def test_joint_order_puts_any_message_into_the_contract_order():
    shuffled = list(reversed(names.JOINT_NAMES))
    order = joint_order(shuffled)
    values = np.arange(16.0)
    assert [shuffled[i] for i in order] == list(names.JOINT_NAMES)
    assert np.array_equal(take_joints(values, order), values[::-1])
    with pytest.raises(MissingJointsError, match="missing joints: home_goalie_slide"):
        joint_order(shuffled[:-1])
    partial = joint_order(["b", "a"], ["a", "b", "c"], allow_missing=True)
    assert partial.tolist() == [1, 0, -1]
    assert np.array_equal(take_joints(np.array([[1.0, 2.0]]), partial), [[2.0, 1.0, np.nan]], equal_nan=True)


def test_geometry_is_read_from_the_parameter_file(tmp_path):
    nominal = TableGeometry.nominal()
    tree = yaml.safe_load(DEFAULT_PARAMS_FILE.read_text())
    assert nominal.half_width == tree["field"]["width"] / 2 == 0.34
    assert nominal.half_length == 0.60 and nominal.goal_half_width == 0.10 and nominal.ball_radius == 0.0175
    assert nominal.rod_y[("home", "attack")] == 0.225 and len(nominal.rod_y) == 8
    other = tmp_path / "small_table.yaml"
    other.write_text("base: regulation_table\nfield: {width: 0.673, length: 1.187}\n")
    small = TableGeometry.of(other)
    assert (small.half_width, small.half_length) == (0.3365, 0.5935)
    assert small == TableGeometry.from_params(load_params(other))


class _Stamp:
    def __init__(self, sec: int, nanosec: int) -> None:
        self.sec, self.nanosec = sec, nanosec


@pytest.mark.parametrize("seconds", [0.0, 1.5, 1763900000.123456789, -0.25])
def test_stamps_round_trip_to_the_nanosecond(seconds):
    stamp = seconds_to_stamp(seconds, _Stamp)
    assert 0 <= stamp.nanosec < 1_000_000_000
    assert stamp_to_seconds(stamp) == pytest.approx(seconds, abs=1e-9)
