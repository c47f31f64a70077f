"""Before/after on a loaded machine: two workers, one per foos_sim version (BEFORE: a source folder put first on its
PYTHONPATH; AFTER: the workspace's), take turns playing bench_sim's target game on the robot table (fast physics,
seed 0, 2 simulated s) and raw 20 kHz mj_step on the same game (1 s), each timed in CPU seconds of its own process
(time.process_time: the load's waiting does not count, its cache and frequency effects do). Prints the medians and
the median of the turn-by-turn ratio.

  python paired.py BEFORE_FOOS_SIM_SRC [TURNS] [robot|servo]   # e.g. a `git archive` of the old commit's ros2_ws/src/foos_sim

The table (robot by default): `servo` plays the same game on params/servo_table.yaml (the default table), to show a
change to the robot drives' code did not make it slower (an argument since sim-2026-11-28-drive-speed-7).
"""
from __future__ import annotations

import os
import statistics
import subprocess
import sys
import time
import types

WORKER = "worker"


def work(table_name: str) -> None:
    from common import ROBOT, SERVO, bench_sim

    from foos_sim.simulation import TableSimulation
    bench = bench_sim()
    bench.time = types.SimpleNamespace(perf_counter=time.process_time)
    params = ROBOT if table_name == "robot" else SERVO
    table, reference = TableSimulation(params, physics="fast"), TableSimulation(params, physics="reference")
    for _ in sys.stdin:
        api = bench.api_cost(table, 0, 2.0)
        raw = bench.raw_cost(reference, 0, 1.0)
        print(f"{api} {raw}", flush=True)


def main() -> None:
    before_src, turns = sys.argv[1], int(sys.argv[2]) if len(sys.argv) > 2 else 15
    table_name = sys.argv[3] if len(sys.argv) > 3 else "robot"
    here = os.path.dirname(os.path.abspath(__file__))
    env_after = dict(os.environ)
    env_before = dict(os.environ, PYTHONPATH=before_src + os.pathsep + os.environ.get("PYTHONPATH", ""))
    workers = {name: subprocess.Popen([sys.executable, os.path.abspath(__file__), WORKER, table_name], cwd=here, env=env,
                                      stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
               for name, env in (("before", env_before), ("after", env_after))}
    results = {name: [] for name in workers}
    for _ in range(turns):
        for name, worker in workers.items():
            worker.stdin.write("go\n")
            worker.stdin.flush()
            api, raw = (float(x) for x in worker.stdout.readline().split())
            results[name].append((api, raw))
    for worker in workers.values():
        worker.stdin.close()
        worker.wait()
    m = statistics.median
    for name, rows in results.items():
        print(f"{name:6s}: API {m(a for a, _ in rows) * 1e3:6.1f} ms CPU per simulated s (least {min(a for a, _ in rows) * 1e3:.1f}), "
              f"raw 20 kHz {m(r for _, r in rows) * 1e3:6.1f} (least {min(r for _, r in rows) * 1e3:.1f}); "
              f"cheaper than raw by {m(r / a for a, r in rows):.2f}x (median of turns)")
    pairs = [b[0] / a[0] for b, a in zip(results["before"], results["after"])]
    print(f"after / before API cost, turn by turn: median {1 / m(pairs):.3f} (after is {m(pairs):.2f}x as fast); "
          f"{turns} turns, {table_name} table, load {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    work(sys.argv[2]) if sys.argv[1:2] == [WORKER] else main()
