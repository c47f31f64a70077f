"""Where a 2 ms fast step's microseconds go on bench_sim's target game (robot table): each part timed in place by a
wrapper (perf_counter), over R repeats of the same seeded 4 s game; per part the least of the repeats (a loaded
machine only adds). Inclusive times, nested parts indented. The wrappers cost about 0.3-1 us a call (compare the
total with the unwrapped API's).

  python budget.py [R]        # run on one core: OMP_NUM_THREADS=1 taskset -c 0 python budget.py 5"""
from __future__ import annotations

import sys

from common import budget

import foos_sim.drive_profiles as drive_profiles


def parts_of(table, mujoco_names) -> list:
    return [(table, "set_command", "set_command (2 per 20 ms)"), (table, "_fast_part", "_fast_part (a whole step)"),
            (table._profiles, "targets", "  ProfileDrives.targets (setpoints)"),
            (table._profiles, "_update", "    _update (a re-plan: state + plan)"),
            (drive_profiles.scurve, "plan", "      scurve.plan"), (drive_profiles.scurve, "state", "      scurve.state"),
            (drive_profiles.scurve, "velocity", "    scurve.velocity (blocks and sub-steps)"),
            (table._sweeps, "window", "  SweepTest.window"), (table._sweeps, "_meeting", "    _meeting"),
            (table._sweeps, "_part", "    _part"),
            (table, "_sub_steps", "  _sub_steps (cut steps, all in them)"),
            (table._profiles, "sub_targets", "    ProfileDrives.sub_targets"),
            (table, "_fast_step", "  _fast_step (every (sub-)step)"), (table._drives, "update", "    FollowingDrives.update"),
            (table._impacts, "resolve", "    ImpactSolver.resolve"), (table._impacts, "_screen", "      _screen"),
            (table._impacts, "_resolve_impacts", "        _resolve_impacts"),
            (table._impacts, "after_step", "    ImpactSolver.after_step"),
            (table._impacts, "set_motion", "  ImpactSolver.set_motion"),
            (mujoco_names, "mj_step1", "  mj_step1"), (mujoco_names, "mj_step2", "  mj_step2")]


if __name__ == "__main__":
    budget(int(sys.argv[1]) if len(sys.argv) > 1 else 5, parts_of)
