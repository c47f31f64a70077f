"""Each effect of the vocabulary, as MuJoCo models it, shows exactly the contract's parameter.

A ball rolls on the ball-only table (same field, walls and contacts as the full model) and the
observed deceleration, drift, bounce or resting height is compared with the parameter file's value.
"""
from __future__ import annotations

import copy

import mujoco
import numpy as np
import pytest
from scipy.optimize import curve_fit

from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim import load_model
from foos_sim.model_builder import ball_model_from_params

R = TableGeometry.nominal().ball_radius


def roll(effects, velocity=(0.0, 2.0), position=(0.0, -0.5), duration=0.5, params=None):
    p = copy.deepcopy(params or load_params())
    p["effects"] = effects
    model = ball_model_from_params(p)
    data = mujoco.MjData(model)
    data.qpos[:3] = (*position, R)
    data.qvel[:2] = velocity
    data.qvel[3:5] = (-velocity[1] / R, velocity[0] / R)
    t, x, v = [], [], []
    for _ in range(int(duration / 1e-3)):
        mujoco.mj_step(model, data, nstep=20)
        t.append(data.time)
        x.append(data.qpos[:3].copy())
        v.append(data.qvel[:3].copy())
    return np.array(t), np.array(x), np.array(v)


def speed(v):
    return np.hypot(v[:, 0], v[:, 1])


def test_nominal_rolling_deceleration_is_the_parameter():
    t, _, v = roll([])
    assert -np.polyfit(t[50:], speed(v)[50:], 1)[0] == pytest.approx(0.15, rel=0.03)


@pytest.mark.parametrize("deceleration", [0.08, 0.4])
def test_rolling_resistance(deceleration):
    t, _, v = roll([{"name": "rolling_resistance", "params": {"deceleration": deceleration}}])
    assert -np.polyfit(t[50:], speed(v)[50:], 1)[0] == pytest.approx(deceleration, rel=0.03)


def test_tilt_drifts_at_five_sevenths_g_slope_downhill():
    # Rolling along y, the ball drifts toward +x (a ball at rest stays: rolling friction holds it).
    t, _, v = roll([{"name": "table_tilt", "params": {"slope_x": 0.01, "slope_y": 0.0}}])
    assert np.polyfit(t[50:], v[50:, 0], 1)[0] == pytest.approx(5 / 7 * 9.81 * 0.01, rel=0.03)  # toward +x


@pytest.mark.parametrize("rate", [0.05, 0.3])
def test_viscous_damping_rate(rate):
    t, _, v = roll([{"name": "viscous_damping", "params": {"rate": rate}}])
    model = lambda tt, v0, k: (v0 + 0.15 / k) * np.exp(-k * tt) - 0.15 / k  # noqa: E731
    fitted = curve_fit(model, t[50:], speed(v)[50:], p0=(2.0, rate))[0][1]
    assert fitted == pytest.approx(rate, rel=0.03)


@pytest.mark.parametrize("coefficient", [0.02, 0.1])
def test_air_drag_coefficient(coefficient):
    t, _, v = roll([{"name": "air_drag", "params": {"coefficient": coefficient}}])
    a = 0.15
    model = lambda tt, v0, c: np.sqrt(a / c) * np.tan(np.arctan(v0 * np.sqrt(c / a)) - np.sqrt(a * c) * tt)  # noqa: E731
    fitted = curve_fit(model, t[50:], speed(v)[50:], p0=(2.0, coefficient))[0][1]
    assert fitted == pytest.approx(coefficient, rel=0.03)


def test_dent_is_where_and_as_deep_as_the_file_says():
    dent = {"name": "surface_dent", "params": {"x": 0.1, "y": 0.2, "radius": 0.08, "depth": 0.003}}
    # Released at rest inside the dent (off-centre in +y), the ball rolls to the bottom.
    t, x, v = roll([dent], velocity=(0.0, 0.0), position=(0.1, 0.23), duration=3.0)
    assert x[:, 2].min() == pytest.approx(R - 0.003, abs=3e-4)
    bottom = x[np.argmin(x[:, 2])]
    assert np.hypot(bottom[0] - 0.1, bottom[1] - 0.2) < 0.01
    # The mirror place is flat: a ball released there stays put at the surface height.
    t, x, v = roll([dent], velocity=(0.0, 0.0), position=(0.1, -0.23), duration=0.2)
    assert x[-1, 2] == pytest.approx(R, abs=1e-4) and np.hypot(*x[-1, :2] - (0.1, -0.23)) < 1e-4


def bounce_ratio(effects, wall_x=+1):
    """Normal speed out / in of a ball rolling straight into a side wall at 1 m/s (just after contact)."""
    p = copy.deepcopy(load_params())
    p["effects"] = effects
    model = ball_model_from_params(p)
    data = mujoco.MjData(model)
    data.qpos[:3] = (wall_x * 0.30, 0.0, R)
    data.qvel[0] = wall_x * 1.0
    data.qvel[4] = wall_x * 1.0 / R
    walls = {i for i in range(model.ngeom) if (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, i) or "").startswith("wall")}
    touched = False
    for _ in range(40000):
        mujoco.mj_step(model, data)
        touching = any(data.contact[i].geom1 in walls or data.contact[i].geom2 in walls for i in range(data.ncon))
        if touching:
            touched = True
        elif touched:
            return -wall_x * data.qvel[0] / 1.0
    raise AssertionError("no bounce")


@pytest.mark.parametrize("e", [0.45, 0.9])
def test_wall_restitution(e):
    assert bounce_ratio([{"name": "wall_restitution", "params": {"coefficient": e}}]) == pytest.approx(e, abs=0.03)


def test_wall_restitution_of_one_wall_only():
    effects = [{"name": "wall_restitution", "params": {"coefficient": 0.5, "wall": "wall_side_pos_x"}}]
    assert bounce_ratio(effects, +1) == pytest.approx(0.5, abs=0.03)
    assert bounce_ratio(effects, -1) == pytest.approx(0.75, abs=0.03)


def test_full_model_loads_with_every_effect(tmp_path):
    f = tmp_path / "table.yaml"
    f.write_text("""base: regulation_table
effects:
  - {name: table_tilt, params: {slope_x: 0.003, slope_y: -0.002}}
  - {name: rolling_resistance, params: {deceleration: 0.2}}
  - {name: viscous_damping, params: {rate: 0.1}}
  - {name: air_drag, params: {coefficient: 0.05}}
  - {name: surface_dent, params: {x: 0.1, y: -0.2, radius: 0.1, depth: 0.002}}
  - {name: wall_restitution, params: {coefficient: 0.6}}
""")
    model = load_model(f)
    assert model.nu == 16 and model.hfield_nrow[0] > 0 and model.opt.viscosity > 0 and model.opt.density > 0
