"""Shared by this log's scripts: the repository root, the parameter files and bench_sim's game (imported from the
script itself, so the games are the bench's). Run with the workspace environment sourced (scripts/env.sh); put a
foos_sim source folder first on PYTHONPATH to measure another version of it."""
from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from pathlib import Path

ROOT = Path(os.environ.get("FOOS_ROOT", Path(__file__).resolve().parents[3]))
PARAMS = ROOT / "ros2_ws/src/foos_core/foos_core/params"
ROBOT, SERVO = str(PARAMS / "robot_table.yaml"), str(PARAMS / "servo_table.yaml")


def bench_sim():
    """scripts/bench_sim as a module (its game(), raw_cost(), api_cost())."""
    os.environ["FOOS_BENCH_SIM_READY"] = "1"  # already in the environment: no re-exec
    loader = importlib.machinery.SourceFileLoader("bench_sim", str(ROOT / "scripts/bench_sim"))
    spec = importlib.util.spec_from_loader("bench_sim", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module


BUDGET_SECONDS = 4.0  # budget(): the seeded game's length, 2000 steps of 2 ms


def budget(repeats: int, parts_of) -> None:
    """Where a 2 ms fast step's microseconds go on bench_sim's target game (robot table): each part that
    parts_of(table, mujoco_names) lists as (owner, attribute, label) timed in place by a wrapper (perf_counter), over
    `repeats` runs of the same seeded game; per part the least of the repeats (a loaded machine only adds). Shared by
    each round's budget.py, which names its parts."""
    import collections
    import time
    import types

    import mujoco

    import foos_sim.simulation as simulation
    from foos_sim.simulation import TableSimulation

    steps = BUDGET_SECONDS * 500
    bench = bench_sim()
    table = TableSimulation(ROBOT, physics="fast")
    plain = [bench.api_cost(table, 0, BUDGET_SECONDS) for _ in range(repeats)]
    spent = collections.defaultdict(lambda: [0.0, 0])

    def wrap(owner, name: str, label: str) -> None:
        inner = getattr(owner, name)

        def timed(*args, **kwargs):
            start = time.perf_counter()
            result = inner(*args, **kwargs)
            entry = spent[label]
            entry[0] += time.perf_counter() - start
            entry[1] += 1
            return result
        setattr(owner, name, timed)

    # MuJoCo's functions are read-only attributes of its module: simulation sees a copy of the module's names.
    simulation.mujoco = types.SimpleNamespace(**{k: getattr(mujoco, k) for k in dir(mujoco) if not k.startswith("__")})
    parts = parts_of(table, simulation.mujoco)
    for owner, name, label in parts:
        wrap(owner, name, label)
    runs, wrapped = collections.defaultdict(list), []
    for _ in range(repeats):
        spent.clear()
        wrapped.append(bench.api_cost(table, 0, BUDGET_SECONDS))
        for label, (seconds, calls) in spent.items():
            runs[label].append((seconds, calls))
    print(f"API unwrapped, least of {repeats}: {min(plain) * 1e3:.1f} ms per simulated s = {min(plain) / 500 * 1e6:.1f} us "
          f"per 2 ms step (repeats {', '.join(f'{x * 1e3:.1f}' for x in plain)}); wrapped {min(wrapped) * 1e3:.1f}")
    for _, _, label in parts:
        if label in runs:
            least, calls = min(s for s, _ in runs[label]), runs[label][0][1]
            print(f"  {label:44s} {calls / steps:6.3f} calls/step {least / calls * 1e6:8.2f} us each "
                  f"{least / steps * 1e6:7.2f} us per step")
