"""Where a 2 ms fast step's microseconds go on bench_sim's target game (robot table): each part timed in place by a
wrapper (perf_counter), over R repeats of the same seeded 4 s game; per part the least of the repeats (a loaded
machine only adds). Inclusive times, nested parts indented. The wrappers cost about 0.3-1 us a call (compare the
total with the unwrapped API's).

  python budget.py [R] [contacts]   # run on one core: OMP_NUM_THREADS=1 taskset -c 0 python budget.py 5
                                    # contacts: ImpactSolver._contacts_for_impacts wrapped too (round 8's rows)

The previous round's script (../sim-2026-11-28-drive-speed/budget.py) with the compiled parts (scurve_lanes.replan and
velocities, the drive following's kernel) wrapped where its numpy functions were; the shared helpers from there."""
from __future__ import annotations

import sys

sys.path.insert(0, str(__import__("pathlib").Path(__file__).resolve().parents[1] / "sim-2026-11-28-drive-speed"))
from common import budget  # noqa: E402

import foos_sim.scurve_lanes as scurve_lanes  # noqa: E402


def parts_of(table, mujoco_names, contacts: bool = False) -> list:
    return [(table, "set_command", "set_command (2 per 20 ms)"), (table, "_fast_part", "_fast_part (a whole step)"),
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
            (mujoco_names, "mj_step1", "  mj_step1"), (mujoco_names, "mj_step2", "  mj_step2")]


if __name__ == "__main__":
    with_contacts = "contacts" in sys.argv[2:]
    budget(int(sys.argv[1]) if len(sys.argv) > 1 else 5, lambda table, names: parts_of(table, names, with_contacts))
