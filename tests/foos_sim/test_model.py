"""The generated model carries the contract's geometry and names, from one parameter file."""
import math
import subprocess
import sys
import textwrap

import mujoco
import numpy as np
import pytest

import foos_sim
from foos_core.names import AXES, JOINT_NAMES, RODS, TEAMS, team_joint_names
from foos_core.table_params import ParamsError, load_params


@pytest.fixture(scope="module")
def model():
    return foos_sim.load_model()


def geom(model, name):
    return model.geom(name)


def test_joints_actuators_and_ball_follow_the_contract(model):
    for name in JOINT_NAMES:
        joint = model.joint(name)
        expected = mujoco.mjtJoint.mjJNT_SLIDE if name.endswith("slide") else mujoco.mjtJoint.mjJNT_HINGE
        assert joint.type[0] == expected
        np.testing.assert_allclose(joint.axis, [1, 0, 0])
        assert model.actuator(name).ctrlrange[1] > 0
    assert model.joint("ball").type[0] == mujoco.mjtJoint.mjJNT_FREE
    assert model.body("ball").id > 0
    ball = model.geom("ball")
    assert ball.size[0] == pytest.approx(0.0175)
    assert model.body("ball").mass[0] == pytest.approx(0.024)
    # A solid sphere: I = 2/5 m r^2.
    np.testing.assert_allclose(model.body("ball").inertia, 0.4 * 0.024 * 0.0175**2, rtol=1e-6)
    assert model.opt.cone == mujoco.mjtCone.mjCONE_ELLIPTIC
    assert model.opt.noslip_iterations > 0
    ball_field = [
        i for i in range(model.npair)
        if {model.geom(model.pair_geom1[i]).name, model.geom(model.pair_geom2[i]).name} == {"ball", "field"}
    ]
    assert len(ball_field) == 1 and model.pair_dim[ball_field[0]] == 6


def test_wall_faces_and_goal_mouths_match_the_regulation_table(model):
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    side = data.geom_xpos[model.geom("wall_side_pos_x").id][0] - model.geom("wall_side_pos_x").size[0]
    end = data.geom_xpos[model.geom("wall_end_away_pos_x").id][1] - model.geom("wall_end_away_pos_x").size[1]
    assert side == pytest.approx(0.34)
    assert end == pytest.approx(0.60)
    mouth_edge = data.geom_xpos[model.geom("wall_end_away_pos_x").id][0] - model.geom("wall_end_away_pos_x").size[0]
    assert mouth_edge == pytest.approx(0.10)
    walls = [model.geom(i).name for i in range(model.ngeom) if model.geom(i).name.startswith("wall")]
    assert len(walls) >= 8
    field_top = data.geom_xpos[model.geom("field").id][2] + model.geom("field").size[2]
    assert field_top == pytest.approx(0.0)


def test_rods_figures_and_travel(model):
    data = mujoco.MjData(model)
    mujoco.mj_forward(model, data)
    expected = {
        "home_goalie": (-0.525, 1), "home_defence": (-0.375, 2), "away_attack": (-0.225, 3),
        "home_midfield": (-0.075, 5), "away_midfield": (0.075, 5), "home_attack": (0.225, 3),
        "away_defence": (0.375, 2), "away_goalie": (0.525, 1),
    }
    for rod, (y, figures) in expected.items():
        assert data.xpos[model.body(rod).id][1] == pytest.approx(y)
        feet = [i for i in range(model.ngeom) if model.geom(i).name.startswith(rod + "_figure") and model.geom(i).name.endswith("_foot")]
        assert len(feet) == figures
        for i in feet:
            bottom = data.geom_xpos[i][2] - model.geom(i).size[2]
            assert 0.0005 < bottom < 0.004, "a foot hangs just above the surface"
        # Travel lets the figures together cover the whole width, without reaching into a wall.
        travel = model.joint(rod + "_slide").range[1]
        xs = sorted(data.geom_xpos[i][0] for i in feet)
        half_foot = model.geom(feet[0]).size[0]
        if figures > 1:
            assert travel >= (xs[1] - xs[0]) / 2 - 0.02
        assert xs[-1] + travel + half_foot <= 0.34 + 1e-9


def test_params_layering_and_bad_files(tmp_path):
    calibrated = tmp_path / "calibrated.yaml"
    calibrated.write_text("base: regulation_table\nball:\n  rolling_deceleration: 0.3\n")
    params = load_params(calibrated)
    assert params["ball"]["rolling_deceleration"] == 0.3
    assert params["ball"]["mass"] == 0.024  # inherited
    model = foos_sim.load_model(calibrated)
    assert model.nu == 16
    with pytest.raises(ParamsError, match="not found"):
        load_params(tmp_path / "missing.yaml")
    broken = tmp_path / "broken.yaml"
    broken.write_text("ball: [unclosed\n")
    with pytest.raises(ParamsError, match="not valid YAML"):
        load_params(broken)
    negative = tmp_path / "negative.yaml"
    negative.write_text("base: regulation_table\nball:\n  mass: -1\n")
    with pytest.raises(ParamsError, match="ball.mass"):
        load_params(negative)


def test_load_model_is_importable_in_a_plain_interpreter():
    code = textwrap.dedent("""
        import foos_sim
        m = foos_sim.load_model()
        print(m.nu, m.opt.timestep)
    """)
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True).stdout.split()
    assert out[0] == "16" and math.isclose(float(out[1]), 5e-5)


def test_command_limits_from_the_params_are_the_built_drives_limits():
    params = load_params()
    for slide, rotate in ((None, None), (2.5, 33.3)):
        if slide is not None:
            params["rods"]["slide_speed_limit"], params["rods"]["rotate_speed_limit"] = slide, rotate
        limits = foos_sim.command_limits(params)
        assert limits.tolist() == [params["rods"][f"{axis}_speed_limit"] for _rod in RODS for axis in AXES]
        sim = foos_sim.TableSimulation(params=params)
        np.testing.assert_array_equal(limits, sim.command_limits)
        for team in TEAMS:
            ctrl = [sim.model.actuator(name).ctrlrange.tolist() for name in team_joint_names(team)]
            assert ctrl == [[-limit, limit] for limit in limits]
