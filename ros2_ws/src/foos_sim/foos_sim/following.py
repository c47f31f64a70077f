"""FollowingDrives.update's rule (foos_sim.drives), compiled (numba): it runs before every fast step and sub-step.

In numpy it was eight passes over the 16 drives and a Python loop over the slides' stops, 9-13 us a step
(docs/measurements/sim-2026-11-28-drive-speed.md); compiled, the call is mostly numba's dispatch (about 0.45 us an
array argument, hence the packed arguments). Plain comparisons and copies: the same bits as the numpy it replaced.
Here, not in foos_sim.drives, so that a process with only the servo table's drives never imports numba (about 0.5 s).
cache=True as in foos_sim.scurve_lanes (compiled once, kept in __pycache__ or numba's per-user cache).
"""
from __future__ import annotations

from numba import njit

REACH, CHANGE, WITHIN = range(3)  # the rows of FollowingDrives' per-drive array
DRIVE, LOW, HIGH = range(3)  # the rows of its stops (a slide's drive index and its free travel)


@njit(cache=True)
def follow(ctrl, qvel, stop_qpos, drives, stops):
    """Before a step: each drive whose target lies within its reach (drives[REACH]: the most its velocity changes
    in the step at its force limit) starts the step at it (qvel set to ctrl); the others keep their velocity and push
    at their limit. drives[CHANGE] gets ctrl - qvel, drives[WITHIN] 1.0 where the drive starts at its target.
    A slide outside its free travel (stop_qpos against stops[LOW], stops[HIGH]) driven further into its stop is left
    to push at its limit: started at its target there, it went 9 mm into MuJoCo's soft stop (5 mm with its force).
    Returns whether every drive started at its target (then nothing changes until a target does or a rod is jolted)."""
    n = ctrl.shape[0]
    for k in range(n):
        change = ctrl[k] - qvel[k]
        drives[CHANGE, k] = change
        drives[WITHIN, k] = 1.0 if abs(change) <= drives[REACH, k] else 0.0
    for j in range(stops.shape[1]):
        position = stop_qpos[j]
        low, high = stops[LOW, j], stops[HIGH, j]
        if not low <= position <= high:
            k = int(stops[DRIVE, j])
            target = ctrl[k]
            if (position > high and target > 0.0) or (position < low and target < 0.0):
                drives[WITHIN, k] = 0.0
    every = True
    for k in range(n):
        if drives[WITHIN, k] != 0.0:
            qvel[k] = ctrl[k]
        else:
            every = False
    return every
