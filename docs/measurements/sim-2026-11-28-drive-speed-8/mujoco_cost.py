"""MuJoCo's own cost on the fast robot model, in CPU microseconds a call: mj_step1 and mj_step2, and mj_kinematics and
mj_collision alone, from the 200 states of bench_sim's target game (seed 0, 4 s, one every 20 ms; each state set with
mj_setState before each call), with MuJoCo's disable flags of what the model does not have (the flags, their effect
on trajectories: flags.py). Variants take turns, 5 rounds; per variant the median of the rounds' means (least in
brackets). Also prints the model's sizes and what each step's constraint rows are.

  python mujoco_cost.py
"""
from __future__ import annotations

import collections
import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import ROBOT, bench_sim  # noqa: E402

from foos_sim.simulation import TableSimulation  # noqa: E402

F = mujoco.mjtDisableBit
VARIANTS = {
    "base": 0,
    "spring|damper": F.mjDSBL_SPRING | F.mjDSBL_DAMPER,
    "equality|frictionloss|sensor": F.mjDSBL_EQUALITY | F.mjDSBL_FRICTIONLOSS | F.mjDSBL_SENSOR,
    "all of those, midphase, filterparent": (F.mjDSBL_SPRING | F.mjDSBL_DAMPER | F.mjDSBL_EQUALITY | F.mjDSBL_FRICTIONLOSS
                                             | F.mjDSBL_SENSOR | F.mjDSBL_MIDPHASE | F.mjDSBL_FILTERPARENT),
}


def timed_pair(model, data, states, spec, first, second) -> tuple[float, float]:
    spent_first = spent_second = 0.0
    for state in states:
        mujoco.mj_setState(model, data, state, spec)
        start = time.process_time()
        first(model, data)
        middle = time.process_time()
        second(model, data)
        spent_first += middle - start
        spent_second += time.process_time() - middle
    return spent_first / len(states) * 1e6, spent_second / len(states) * 1e6


def main() -> None:
    bench = bench_sim()
    sim = TableSimulation(ROBOT, physics="fast")
    model, data = sim.model, sim.data
    print(f"ngeom {model.ngeom}, npair {model.npair}, nbody {model.nbody}, nv {model.nv}, nu {model.nu}, limited joints "
          f"{int(model.jnt_limited.sum())}; stiffness {np.abs(model.jnt_stiffness).max()}, damping {np.abs(model.dof_damping).max()}, "
          f"frictionloss {np.abs(model.dof_frictionloss).max()}, neq {model.neq}, nsensor {model.nsensor}")
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS | mujoco.mjtState.mjSTATE_CTRL | mujoco.mjtState.mjSTATE_XFRC_APPLIED
    size = mujoco.mj_stateSize(model, spec)
    states, rows = [], collections.Counter()

    def step() -> None:
        sim.advance(0.02)
        state = np.empty(size)
        mujoco.mj_getState(model, data, state, spec)
        states.append(state)
        rows[(data.ncon, data.nefc)] += 1
    bench.game(sim, 0, 4.0, step)
    print(f"{len(states)} states; (contacts, constraint rows) after the steps: {dict(rows.most_common(8))}")
    base = model.opt.disableflags
    results = {name: collections.defaultdict(list) for name in VARIANTS}
    for _ in range(5):
        for name, flags in VARIANTS.items():
            model.opt.disableflags = base | int(flags)
            one, two = timed_pair(model, data, states, spec, mujoco.mj_step1, mujoco.mj_step2)
            kinematics, collision = timed_pair(model, data, states, spec, mujoco.mj_kinematics, mujoco.mj_collision)
            for part, value in (("mj_step1", one), ("mj_step2", two), ("mj_kinematics", kinematics), ("mj_collision", collision)):
                results[name][part].append(value)
    model.opt.disableflags = base
    for name, parts in results.items():
        print(f"{name:38s} " + "  ".join(f"{part} {np.median(v):6.2f} ({min(v):6.2f})" for part, v in parts.items()))


if __name__ == "__main__":
    main()
