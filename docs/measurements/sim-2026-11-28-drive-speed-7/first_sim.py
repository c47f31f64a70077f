"""What a fresh process pays before its first simulated second (wall clock): importing foos_sim.simulation, the first
TableSimulation's construction and its first simulated second (bench_sim's target game, seed 0: kicks and sub-steps,
so every compiled function runs), with numba's cache cold (an empty NUMBA_CACHE_DIR: everything compiles) and warm
(the same directory again: loaded from it). Each case in its own fresh process, R times; medians.

  python first_sim.py [R] [BEFORE_FOOS_SIM_SRC]     # with BEFORE: the old code's fresh process too"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

HERE = Path(__file__).resolve().parent
COMMON = HERE.parent / "sim-2026-11-28-drive-speed"
CHILD = f"""
import sys, time
start = time.perf_counter()
sys.path.insert(0, {str(COMMON)!r})
from foos_sim.simulation import TableSimulation
imported = time.perf_counter()
from common import bench_sim
bench = bench_sim()
params = sys.argv[1]
sim = TableSimulation(params, physics="fast")
built = time.perf_counter()
bench.game(sim, 0, 1.0, lambda: sim.advance(0.02))
played = time.perf_counter()
print(imported - start, built - imported, played - built, 'numba' in sys.modules)
"""


def run(params: str, env: dict) -> list[float]:
    out = subprocess.run([sys.executable, "-c", CHILD, params], env=env, capture_output=True, text=True, check=True)
    *times, numba = out.stdout.split()
    return [float(t) for t in times] + [numba == "True"]


def main(repeats: int, before: str | None) -> None:
    sys.path.insert(0, str(COMMON))
    from common import ROBOT, SERVO
    cases = []
    with tempfile.TemporaryDirectory() as warm_dir:
        run(ROBOT, dict(os.environ, NUMBA_CACHE_DIR=warm_dir))  # fill the warm cache
        for _ in range(repeats):
            with tempfile.TemporaryDirectory() as cold_dir:
                cases.append(("robot, cache cold", run(ROBOT, dict(os.environ, NUMBA_CACHE_DIR=cold_dir))))
            cases.append(("robot, cache warm", run(ROBOT, dict(os.environ, NUMBA_CACHE_DIR=warm_dir))))
            cases.append(("servo (default)", run(SERVO, dict(os.environ, NUMBA_CACHE_DIR=warm_dir))))
            if before:
                old = dict(os.environ, PYTHONPATH=before + os.pathsep + os.environ.get("PYTHONPATH", ""))
                cases.append(("robot, before (no numba)", run(ROBOT, old)))
    for name in dict(cases):
        rows = [r for n, r in cases if n == name]
        med = [statistics.median(r[k] for r in rows) for k in range(3)]
        print(f"{name:26s} import {med[0]:.2f} s, construction {med[1]:.2f} s, first simulated second {med[2]:.2f} s; "
              f"total {sum(med):.2f} s (median of {len(rows)}); numba imported: {rows[0][3]}")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 3, sys.argv[2] if len(sys.argv) > 2 else None)
