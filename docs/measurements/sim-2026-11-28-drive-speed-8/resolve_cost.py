"""CPU microseconds of one ImpactSolver.resolve call (the impact screen, and any impacts it resolves) on the states of
bench_sim's target game: the game is played once, its state kept after every 20 ms; each state is set, MuJoCo's
mj_step1 run, and resolve timed (process_time), 7 passes, per state the least, then the mean over the states. Run it
once per version (a foos_sim source first on PYTHONPATH for the old one) right after each other.

  python resolve_cost.py robot|servo [SECONDS]
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import ROBOT, SERVO, bench_sim  # noqa: E402

from foos_sim.simulation import TableSimulation  # noqa: E402

PASSES = 7


def main(table_name: str, seconds: float) -> None:
    bench = bench_sim()
    sim = TableSimulation(ROBOT if table_name == "robot" else SERVO, physics="fast")
    model, data, impacts = sim.model, sim.data, sim._impacts
    spec = mujoco.mjtState.mjSTATE_INTEGRATION
    size = mujoco.mj_stateSize(model, spec)
    states = []

    def step() -> None:
        sim.advance(0.02)
        state = np.empty(size)
        mujoco.mj_getState(model, data, state, spec)
        states.append((state, impacts.reachable))
    bench.game(sim, 0, seconds, step)
    least = np.full(len(states), np.inf)
    due = 0
    for _ in range(PASSES):
        for k, (state, reachable) in enumerate(states):
            mujoco.mj_setState(model, data, state, spec)
            mujoco.mj_step1(model, data)
            impacts.reachable = reachable
            start = time.process_time()
            struck = impacts.resolve(data)
            least[k] = min(least[k], time.process_time() - start)
            due += struck
    print(f"{table_name}: {len(states)} states, {due // PASSES} with an impact; resolve {least.mean() * 1e6:.2f} us a call "
          f"(mean of per-state least of {PASSES}), {np.median(least) * 1e6:.2f} median, without impacts "
          f"{np.mean(np.sort(least)[:len(least) - due // PASSES]) * 1e6:.2f}")


if __name__ == "__main__":
    if len(sys.argv) not in (2, 3) or sys.argv[1] not in ("robot", "servo"):
        sys.exit("usage: resolve_cost.py robot|servo [SECONDS]")
    main(sys.argv[1], float(sys.argv[2]) if len(sys.argv) == 3 else 10.0)
