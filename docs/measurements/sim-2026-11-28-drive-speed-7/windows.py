"""The compiled sweep scan (foos_sim.sweep_scan) against the Python SweepTest.window it replaced, on random states:
ball anywhere on the field (on it or in the air, up to 12 m/s, some falling), rods at random angles and slides, their
velocities and targets up to the drives' limits, steps of 2 ms and sub-steps. Every window field compared exactly.

  python windows.py BEFORE_FOOS_SIM_SRC [N]     # e.g. a `git archive` of the old commit's ros2_ws/src/foos_sim"""
from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import ROBOT  # noqa: E402

from foos_sim.simulation import TableSimulation  # noqa: E402


def main(before_src: str, n: int) -> None:
    spec = importlib.util.spec_from_file_location("old_sweeps", Path(before_src) / "foos_sim" / "sweeps.py")
    old = importlib.util.module_from_spec(spec)
    sys.modules["old_sweeps"] = old  # (dataclasses look their module up)
    spec.loader.exec_module(old)
    sim = TableSimulation(ROBOT, physics="fast")
    new = sim._sweeps
    before = old.SweepTest(sim.params, [old.RodIndex(**vars(r)) for r in new.rods], new.figure_reach, new.ball_qpos,
                           new.ball_qvel, new.walls)
    rng = np.random.default_rng(0)
    qpos, qvel, ctrl = sim.data.qpos.copy(), sim.data.qvel.copy(), sim.data.ctrl.copy()
    b, bv = new.ball_qpos, new.ball_qvel
    hx, hy = sim.half_width, sim.half_length
    kinds, differ = {"none": 0, "window": 0, "several rods": 0}, 0
    for k in range(n):
        qpos[:] = sim.data.qpos
        for rod in new.rods:
            qpos[rod.rotate_qpos] = rng.uniform(-np.pi, np.pi)
            qpos[rod.slide_qpos] = rng.uniform(-0.1, 0.1)
            qvel[rod.rotate_dof], ctrl[rod.rotate_ctrl] = rng.choice([0.0, 1.0]) * rng.uniform(-314, 314, 2)
            qvel[rod.slide_dof], ctrl[rod.slide_ctrl] = rng.choice([0.0, 1.0]) * rng.uniform(-3.5, 3.5, 2)
        # near a rod along the table half the time (the scans that do something)
        y = rng.choice([r.y for r in new.rods]) + rng.uniform(-0.08, 0.08) if k % 2 else rng.uniform(-hy, hy)
        qpos[b:b + 3] = rng.uniform(-hx, hx), y, rng.choice([sim.ball_radius, rng.uniform(sim.ball_radius, 0.09)])
        qvel[bv:bv + 3] = rng.uniform(-1, 1, 3) * rng.choice([0.0, 0.5, 3.0, 12.0]) * [1.0, 1.0, rng.choice([0.0, 1.0])]
        h = rng.choice([0.002, 0.002, 0.0011, 0.00013])
        w_old = before.window(qpos.tolist(), qvel.tolist(), ctrl.tolist(), h)
        w_new = new.window(qpos, qvel, ctrl, h)
        same = (w_old.start, w_old.end, w_old.turning, w_old.figure_speed, w_old.reachable) == (
            w_new.start, w_new.end, w_new.turning, w_new.figure_speed, w_new.reachable)
        differ += not same
        kinds["none" if w_old is old.NO_WINDOW else ("several rods" if len(w_old.reachable) > 1 else "window")] += 1
    print(f"{n} states: {differ} windows differ; old windows: {kinds}")


if __name__ == "__main__":
    main(sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 20000)
