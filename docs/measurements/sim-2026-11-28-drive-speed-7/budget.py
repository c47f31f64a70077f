"""Where a 2 ms fast step's microseconds go on bench_sim's target game (robot table): each part timed in place by a
wrapper (perf_counter), over R repeats of the same seeded 4 s game; per part the least of the repeats (a loaded
machine only adds). Inclusive times, nested parts indented. The wrappers cost about 0.3-1 us a call (compare the
total with the unwrapped API's).

  python budget.py [R] [contacts]   # run on one core: OMP_NUM_THREADS=1 taskset -c 0 python budget.py 5
                                    # contacts: ImpactSolver._contacts_for_impacts wrapped too (round 8's rows)

The previous round's script (../sim-2026-11-28-drive-speed/budget.py) with the compiled parts (scurve_lanes.replan and
velocities, the drive following's kernel) wrapped where its numpy functions were; the shared helpers from there."""
from __future__ import annotations

import collections
import sys
import time
import types

import mujoco

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import ROBOT, bench_sim  # noqa: E402

import foos_sim.scurve_lanes as scurve_lanes  # noqa: E402
import foos_sim.simulation as simulation  # noqa: E402
from foos_sim.simulation import TableSimulation  # noqa: E402

SECONDS = 4.0
STEPS = SECONDS * 500


def main(repeats: int, contacts: bool = False) -> None:
    bench = bench_sim()
    table = TableSimulation(ROBOT, physics="fast")
    plain = [bench.api_cost(table, 0, SECONDS) for _ in range(repeats)]
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
    parts = [(table, "set_command", "set_command (2 per 20 ms)"), (table, "_fast_part", "_fast_part (a whole step)"),
             (table._profiles, "targets", "  ProfileDrives.targets (setpoints)"),
             (table._profiles, "_update", "    _update (a re-plan: state + plan)"),
             (scurve_lanes, "replan", "      scurve_lanes.replan (compiled)"),
             (scurve_lanes, "velocities", "    scurve_lanes.velocities (blocks and sub-steps, compiled)"),
             (table._sweeps, "window", "  SweepTest.window (the scan compiled)"),
             (table, "_sub_steps", "  _sub_steps (cut steps, all in them)"),
             (table._profiles, "sub_targets", "    ProfileDrives.sub_targets"),
             (table, "_fast_step", "  _fast_step (every (sub-)step)"), (table._drives, "update", "    FollowingDrives.update"),
             (table._drives, "_follow", "      following.follow (compiled)"),
             (table._impacts, "resolve", "    ImpactSolver.resolve"), (table._impacts, "_screen", "      _screen"),
             (table._impacts, "_resolve_impacts", "        _resolve_impacts"),
             *([(table._impacts, "_contacts_for_impacts", "        _contacts_for_impacts")] if contacts else []),
             (table._impacts, "after_step", "    ImpactSolver.after_step"),
             (table._impacts, "set_motion", "  ImpactSolver.set_motion"),
             (simulation.mujoco, "mj_step1", "  mj_step1"), (simulation.mujoco, "mj_step2", "  mj_step2")]
    for owner, name, label in parts:
        wrap(owner, name, label)
    runs, wrapped = collections.defaultdict(list), []
    for _ in range(repeats):
        spent.clear()
        wrapped.append(bench.api_cost(table, 0, SECONDS))
        for label, (seconds, calls) in spent.items():
            runs[label].append((seconds, calls))
    print(f"API unwrapped, least of {repeats}: {min(plain) * 1e3:.1f} ms per simulated s = {min(plain) / 500 * 1e6:.1f} us "
          f"per 2 ms step (repeats {', '.join(f'{x * 1e3:.1f}' for x in plain)}); wrapped {min(wrapped) * 1e3:.1f}")
    for _, _, label in parts:
        if label in runs:
            least, calls = min(s for s, _ in runs[label]), runs[label][0][1]
            print(f"  {label:44s} {calls / STEPS:6.3f} calls/step {least / calls * 1e6:8.2f} us each "
                  f"{least / STEPS * 1e6:7.2f} us per step")


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 5, "contacts" in sys.argv[2:])
