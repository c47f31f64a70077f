"""MuJoCo side of calibration: the fitted effects as a parameter tree, and batched ball rollouts.

Bounces (wall restitution) and the measured gain are computed with the real MuJoCo table (the
ball-only model: same field, walls and effects, no rods), never with the fitting surrogate.
"""
from __future__ import annotations

import copy
from typing import Sequence

import mujoco
import numpy as np
from mujoco import rollout as mj_rollout

from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.model_builder import TableModelBuilder, ball_model_from_params

from . import surrogate

CHUNK = 2000  # physics steps per rollout call (keeps the state output small)
THREADS = 2


def effects_list(names: Sequence[str], theta: np.ndarray, restitution: float | None = None) -> list[dict]:
    """The contract's effect entries for the named effects with parameter vector theta."""
    out = []
    for name in names:
        if name == "table_tilt":
            out.append({"name": name, "params": {"slope_x": float(theta[0]), "slope_y": float(theta[1])}})
        elif name == "rolling_resistance":
            out.append({"name": name, "params": {"deceleration": float(theta[2])}})
        elif name == "viscous_damping":
            out.append({"name": name, "params": {"rate": float(theta[3])}})
        elif name == "air_drag":
            out.append({"name": name, "params": {"coefficient": float(theta[4])}})
        elif name == "surface_dent":
            out.append({"name": name, "params": {"x": float(theta[5]), "y": float(theta[6]),
                                                 "radius": float(theta[7]), "depth": float(theta[8])}})
    if restitution is not None:
        out.append({"name": "wall_restitution", "params": {"coefficient": float(restitution)}})
    return out


def theta_of(params: dict) -> np.ndarray:
    """The surrogate's parameter vector of a table (its effects on top of its rolling resistance)."""
    theta = surrogate.nominal_theta(float(params["ball"]["rolling_deceleration"]))
    for effect in params.get("effects", []) or []:
        name, p = effect.get("name"), effect.get("params", {})
        if name == "table_tilt":
            theta[0:2] = (p["slope_x"], p["slope_y"])
        elif name == "rolling_resistance":
            theta[2] = p["deceleration"]
        elif name == "viscous_damping":
            theta[3] = p["rate"]
        elif name == "air_drag":
            theta[4] = p["coefficient"]
        elif name == "surface_dent" and not theta[8]:
            theta[5:9] = (p["x"], p["y"], p["radius"], p["depth"])
    return theta


def restitution_of(params: dict) -> float:
    for effect in params.get("effects", []) or []:
        if effect.get("name") == "wall_restitution" and effect.get("params", {}).get("wall", "*") == "*":
            return float(effect["params"]["coefficient"])
    return float(params["walls"]["restitution"])


def base_effect_names(params: dict) -> list[str]:
    return [e["name"] for e in params.get("effects", []) or [] if e.get("name") != "wall_restitution"]


def params_with(effects: list[dict], base: dict | None = None) -> dict:
    tree = copy.deepcopy(base if base is not None else load_params())
    tree["effects"] = copy.deepcopy(effects)
    return tree


class BallRollouts:
    """Batched free-ball rollouts on ball-only MuJoCo tables (one model per batch row)."""

    def __init__(self, params_trees: Sequence[dict]):
        self.models = [ball_model_from_params(p) for p in params_trees]
        self.radius = TableGeometry.from_params(params_trees[0]).ball_radius
        self.timestep = float(self.models[0].opt.timestep)
        self.datas = [mujoco.MjData(self.models[0]) for _ in range(THREADS)]
        self.spec = mujoco.mjtState.mjSTATE_FULLPHYSICS

    def initial_states(self, model_index: Sequence[int], states: np.ndarray) -> np.ndarray:
        """Full physics states of balls rolling without slip from (x, y, vx, vy) rows."""
        out = []
        for k, (x, y, vx, vy) in zip(model_index, states):
            m = self.models[k]
            d = self.datas[0]
            mujoco.mj_resetData(m, d)
            d.qpos[:7] = (x, y, self.radius, 1, 0, 0, 0)
            d.qvel[:6] = (vx, vy, 0, -vy / self.radius, vx / self.radius, 0)
            s = np.empty(mujoco.mj_stateSize(m, self.spec))
            mujoco.mj_getState(m, d, s, self.spec)
            out.append(s)
        return np.array(out)

    def positions(self, model_index: Sequence[int], states: np.ndarray, duration: float,
                  sample_dt: float = 0.005) -> tuple[np.ndarray, np.ndarray]:
        """Ball (x, y) every sample_dt from each initial state: times (K,), positions (n, K, 2)."""
        model_index = list(model_index)
        models = [self.models[k] for k in model_index]
        state = self.initial_states(model_index, states)
        every = max(1, int(round(sample_dt / self.timestep)))
        total = int(round(duration / self.timestep))
        qpos0 = 1 + 0  # FULLPHYSICS layout: time, then qpos
        samples = [state[:, qpos0:qpos0 + 2].copy()]
        done = 0
        while done < total:
            n = min(CHUNK, total - done)
            n -= n % every if n >= every else 0
            n = max(n, 1)
            out, _ = mj_rollout.rollout(models, self.datas, state, nstep=n)
            for k in range(every - 1, n, every):
                samples.append(out[:, k, qpos0:qpos0 + 2].copy())
            state = out[:, -1].copy()
            done += n
        times = np.arange(len(samples)) * every * self.timestep
        return times, np.stack(samples, axis=1)


def set_wall_restitution(model: mujoco.MjModel, params: dict, restitution: float) -> None:
    """Change every ball-wall contact pair of a built model to another restitution."""
    builder = TableModelBuilder(params, ball_only=True)
    solref = np.array([float(v) for v in builder.solref(restitution=restitution).split()])
    for i in range(model.npair):
        g1, g2 = model.pair_geom1[i], model.pair_geom2[i]
        names = (mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g1) or "", mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_GEOM, g2) or "")
        if any(n.startswith("wall") for n in names):
            model.pair_solref[i] = solref
