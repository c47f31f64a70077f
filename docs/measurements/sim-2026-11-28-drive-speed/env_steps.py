"""RL env steps/s on the robot table (hardened reset, scripted opponent, random actions): 3 x 600 steps, median, per
wall second (as bench_policy) and per CPU second of the process;
`save FILE` / `compare FILE` also keeps or checks every observation, reward and MuJoCo state (seeded)."""
from __future__ import annotations

import statistics
import sys
import time

import numpy as np
from common import ROBOT

from foos_policy.env import FoosballEnv

rates, cpu_rates, runs = [], [], []
for seed in range(3):
    env = FoosballEnv("hardened", "scripted", params_file=ROBOT)
    rng = np.random.default_rng(seed)
    obs, _ = env.reset(seed=seed)
    rows = [obs]
    start, cpu_start = time.perf_counter(), time.process_time()
    for _ in range(600):
        obs, reward, terminated, truncated, _ = env.step(rng.uniform(-20, 20, 8))
        rows.append(np.concatenate([obs, [reward], env.sim.data.qpos, env.sim.data.qvel]))
        if terminated or truncated:
            obs, _ = env.reset()
    rates.append(600 / (time.perf_counter() - start))
    cpu_rates.append(600 / (time.process_time() - cpu_start))  # CPU seconds of this process: the load's waiting left out
    runs.append(np.concatenate([np.ravel(r) for r in rows]))
print(f"env steps/s median {statistics.median(rates):.0f} (per repeat {', '.join(f'{r:.0f}' for r in rates)}); per CPU second "
      f"{statistics.median(cpu_rates):.0f} ({', '.join(f'{r:.0f}' for r in cpu_rates)})")
if len(sys.argv) == 3 and sys.argv[1] == "save":
    np.savez(sys.argv[2], *runs)
elif len(sys.argv) == 3 and sys.argv[1] == "compare":
    saved = np.load(sys.argv[2])
    for i, run in enumerate(runs):
        print(f"env seed {i}: {'bit-identical' if np.array_equal(run, saved[f'arr_{i}']) else 'DIFFERENT'}")
