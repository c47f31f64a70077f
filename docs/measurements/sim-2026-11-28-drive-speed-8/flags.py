"""Which of MuJoCo's disable flags leave the fast robot table's trajectories unchanged: bench_sim's target game (seed 0,
2 s, the state after every 20 ms) played with each flag set in turn against the game without; prints the largest
difference in qpos/qvel and the game's CPU seconds (one run each: a loaded machine's figure, read with mujoco_cost.py).

  python flags.py
"""
from __future__ import annotations

import sys
import time
from pathlib import Path

import mujoco
import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import ROBOT, bench_sim  # noqa: E402

from foos_sim.simulation import TableSimulation  # noqa: E402


def main() -> None:
    bench = bench_sim()
    sim = TableSimulation(ROBOT, physics="fast")
    model, data = sim.model, sim.data
    base = model.opt.disableflags

    def play(flag: int) -> tuple[np.ndarray, float]:
        model.opt.disableflags = base | flag
        rows = []
        sim.reset()

        def step() -> None:
            sim.advance(0.02)
            rows.append(np.concatenate([data.qpos, data.qvel]))
        start = time.process_time()
        bench.game(sim, 0, 2.0, step)
        return np.array(rows), time.process_time() - start

    reference, seconds = play(0)
    print(f"{'none':22s} CPU {seconds:.3f} s")
    for name, bit in mujoco.mjtDisableBit.__members__.items():
        if name == "mjNDISABLE":
            continue
        rows, seconds = play(int(bit))
        print(f"{name:22s} largest difference {np.abs(rows - reference).max():.3g}  CPU {seconds:.3f} s")
    model.opt.disableflags = base


if __name__ == "__main__":
    main()
