"""Identical trajectories before and after: bench_sim's games (the target's and the calm one) with their seeds, the
whole MuJoCo state (qpos, qvel, ctrl), the time and the touch counts after every 20 ms; `save FILE` or `compare FILE`.

  robot table, fast physics: seeds 0-2, 5 s each; the same with commands every 100 ms instead of 20 (a plan followed
  for longer than a setpoint chunk), seeds 0-1; servo table, fast: seeds 0-1, 5 s; robot table, reference: seeds 0-1,
  1 s."""
from __future__ import annotations

import sys

import numpy as np
from common import ROBOT, SERVO, bench_sim

from foos_sim.simulation import TableSimulation

GAMES = (("robot_fast", ROBOT, "fast", 3, 5.0, 0.02), ("robot_fast_held", ROBOT, "fast", 2, 5.0, 0.1),
         ("servo_fast", SERVO, "fast", 2, 5.0, 0.02), ("robot_reference", ROBOT, "reference", 2, 1.0, 0.02))


def record() -> dict:
    bench = bench_sim()
    out = {}
    for name, params, physics, seeds, seconds, period in GAMES:
        bench.CONTROL_PERIOD = period  # game() reads it as it plays
        sim = TableSimulation(params, physics=physics)
        for seed in range(seeds):
            for calm in (False, True):
                rows = []
                sim.reset()

                def step():
                    sim.advance(period)
                    rows.append(np.concatenate([sim.data.qpos, sim.data.qvel, sim.data.ctrl, [sim.time], sim.figure_touches()]))
                bench.game(sim, seed, seconds, step, calm=calm)
                out[f"{name}_{seed}_{'calm' if calm else 'target'}"] = np.array(rows)
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3 or sys.argv[1] not in ("save", "compare"):
        sys.exit("usage: identity.py save|compare FILE.npz")
    games = record()
    if sys.argv[1] == "save":
        np.savez(sys.argv[2], **games)
    else:
        saved = np.load(sys.argv[2])
        for key, rows in games.items():
            print(f"{key}: {rows.shape[0]} states, largest difference {np.abs(rows - saved[key]).max():.3g}"
                  f"{' (bit-identical)' if np.array_equal(rows, saved[key]) else ''}")
