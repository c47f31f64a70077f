"""The sweep test's scan (foos_sim.sweeps.SweepTest.window), compiled (numba): which part of the next fast step a
figure can touch the ball in. The rules are explained in foos_sim.sweeps; this module is their only code.

It runs before every fast step on the jerk-limited drives: in Python the per-rod scan, the conservative advancement
and the sector test cost 12-21 us a step (docs/measurements/sim-2026-11-28-drive-speed.md), compiled about what numba's
dispatch costs (the arguments packed: about 0.45 us an array argument). Scalar arithmetic in the order the Python had
(no fastmath): the windows, hence the sub-steps, are the same bits. Python's `round` rounds half to even as numba's
does; math.remainder, which numba lacks, is CPython's exact algorithm (_remainder). Imported by SweepTest only when a
window is asked for (the jerk-limited drives), so the servo table's processes never import numba.
cache=True as in foos_sim.scurve_lanes.
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit

# The columns of a rod's row (SweepTest._rods, sorted by y).
Y, SLIDE_DOF, ROTATE_DOF, SLIDE_CTRL, ROTATE_CTRL, SLIDE_QPOS, ROTATE_QPOS, FIGURES, SPACING = range(9)
ROD_COLUMNS = 9
# The entries of the figure's and the table's shape (SweepTest._shape).
(BALL_QPOS, BALL_QVEL, WALL_X, WALL_Y, WALL_Z, FLOOR, AXIS_HEIGHT, FOOT_REACH, FOOT_HALF, HEAD_HALF, HEAD_REACH, ACROSS,
 FIGURE_REACH, RADIUS, LOW0, HIGH0, THICK0, WIDE0, LOW1, HIGH1, THICK1, WIDE1, FIGURE_STEP, LEAST_FIGURE_SPEED) = range(24)
SHAPE_SIZE = 24
# The window's entries in `out`, then a flag per rod (1.0 where its figure can touch the ball).
START, END, TURNING, SPEED = range(4)
WINDOW_SIZE = 4
_TINY = 1e-9
_TWO_PI = 2.0 * math.pi


@njit(cache=True)
def window(qpos, qvel, ctrl, h, rods, shape, out):
    """The part of the next step of h in which a figure can touch the ball, written to out (START, END, TURNING,
    SPEED, then a flag per rod); the number of rods that can (0: none, out's window undefined)."""
    b, bv = int(shape[BALL_QPOS]), int(shape[BALL_QVEL])
    bx, by, bz = qpos[b], qpos[b + 1], qpos[b + 2]
    vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
    # On a straight path through the step (no wall or cover reached) the figures' meeting times are found exactly
    # (_meeting); a path that bounces takes the sectors widened by the ball's travel (_part).
    straight = (abs(bx + vx * h) < shape[WALL_X] and abs(by + vy * h) < shape[WALL_Y] and bz + vz * h < shape[WALL_Z]
                and (vz > -1e-3 or bz + vz * h > shape[FLOOR]))
    n = rods.shape[0]
    striking = np.zeros(n)
    found = _scan(qpos, qvel, ctrl, h, straight, 0.0, striking, rods, shape, out)
    if found:
        # The ball may bounce off a figure that can strike it and leave its straight path within the step: for the
        # other rods its travel then bounds where it goes (the sector test), in any direction, its speed raised by
        # at most twice the striking figure's until the step is planned again (after the sub-step of an impact, or
        # the step's end). Where another rod can touch it too, every rod takes the sector test.
        for k in range(n):
            striking[k] = out[WINDOW_SIZE + k]
        fine = out[TURNING] * h * (out[END] - out[START]) > shape[FIGURE_STEP]
        extra = 2.0 * out[SPEED] * (shape[FIGURE_STEP] / out[TURNING] if fine else h)
        found = _scan(qpos, qvel, ctrl, h, straight, extra, striking, rods, shape, out)
        more = False
        for k in range(n):
            if out[WINDOW_SIZE + k] != 0.0 and striking[k] == 0.0:
                more = True
        if more:
            striking[:] = 0.0
            found = _scan(qpos, qvel, ctrl, h, False, extra, striking, rods, shape, out)
    if found and out[END] < out[START]:
        return 0
    return found


@njit(cache=True)
def _scan(qpos, qvel, ctrl, h, straight, extra, exempt, rods, shape, out):
    """The union of the rods' windows (out) and how many rods have one. On a straight path each rod's meeting times
    (_meeting), or with `extra` travel the sector test for all but the `exempt` rods (flags)."""
    b, bv = int(shape[BALL_QPOS]), int(shape[BALL_QVEL])
    bx, by, bz = qpos[b], qpos[b + 1], qpos[b + 2]
    vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
    axis_height, foot_reach = shape[AXIS_HEIGHT], shape[FOOT_REACH]
    travel = math.sqrt(vx * vx + vy * vy + vz * vz) * h + extra
    # The ball's centre stays at least this far below the axes through the step (gravity only lowers it).
    below = axis_height - (bz + (vz if vz > 0.0 else 0.0) * h) - extra
    reach = foot_reach + travel
    n = rods.shape[0]
    for k in range(n):
        out[WINDOW_SIZE + k] = 0.0
    i = 0
    while i < n and rods[i, Y] < by - reach:  # bisect_left on the rods' y
        i += 1
    if i == n or rods[i, Y] > by + reach:
        return 0  # no rod within a foot's reach along the table
    count = 0
    speed, turning, start, end = shape[LEAST_FIGURE_SPEED], 0.0, 1.0, 0.0  # no part yet: start > end
    while i < n and rods[i, Y] <= by + reach:
        rod = i
        i += 1
        dy, dz = by - rods[rod, Y], bz - axis_height
        rho = math.sqrt(dy * dy + dz * dz)
        closest = rho - travel
        if below > closest:
            closest = below
        if closest > foot_reach:
            continue
        # Across the table: the ball within reach of the figure nearest to it (the rod slides in the step too).
        across = bx - qpos[int(rods[rod, SLIDE_QPOS])]
        figures, spacing = rods[rod, FIGURES], rods[rod, SPACING]
        middle = (figures - 1.0) / 2  # figure k sits at (k - middle) * spacing from the rod's centre
        nearest = 0.0
        if figures > 1.0:
            index = float(round(across / spacing + middle))
            if index < 0.0:
                index = 0.0
            if index > figures - 1.0:
                index = figures - 1.0
            nearest = (index - middle) * spacing
        slide_now, slide_target = abs(qvel[int(rods[rod, SLIDE_DOF])]), abs(ctrl[int(rods[rod, SLIDE_CTRL])])
        slide_speed = slide_target if slide_target > slide_now else slide_now
        if abs(across - nearest) > shape[ACROSS] + travel + slide_speed * h:
            continue
        now, target = qvel[int(rods[rod, ROTATE_DOF])], ctrl[int(rods[rod, ROTATE_CTRL])]
        fastest = abs(target) if abs(target) > abs(now) else abs(now)
        if straight and (extra == 0.0 or exempt[rod] != 0.0):
            met, part_start, part_end = _meeting(rods, rod, qpos, qvel, ctrl, h, nearest, shape)
        else:
            met, part_start, part_end = _part(qpos[int(rods[rod, ROTATE_QPOS])], now, target, h, math.atan2(dy, -dz),
                                              closest, travel, shape)
        if not met:
            continue
        rim = fastest * shape[FIGURE_REACH]
        if rim > turning:
            turning = rim
        if slide_speed + rim > speed:
            speed = slide_speed + rim
        if part_start < start:
            start = part_start
        if part_end > end:
            end = part_end
        out[WINDOW_SIZE + rod] = 1.0
        count += 1
    out[START], out[END], out[TURNING], out[SPEED] = start, end, turning, speed
    return count


@njit(cache=True, inline="always")
def _block_distance(along, side, x, low, high, thick, wide):
    ds = low - along if along < low else (along - high if along > high else 0.0)
    dl = side - thick if side > thick else 0.0
    dx = x - wide if x > wide else 0.0
    return ds * ds + dl * dl + dx * dx


@njit(cache=True, inline="always")
def _gap(t, angle, turn, px, py, pz, vx, vy, vz, slide, lag, shape):
    """The distance between the figure's blocks and the ball t into the step, less the ball's radius (and margin)
    and what a lagging drive may be off its path by then."""
    theta = angle + turn * t
    sin, cos = math.sin(theta), math.cos(theta)
    y, z = py + vy * t, pz + vz * t
    along, side, x = y * sin - z * cos, abs(y * cos + z * sin), abs(px + (vx - slide) * t)
    least = _block_distance(along, side, x, shape[LOW0], shape[HIGH0], shape[THICK0], shape[WIDE0])  # the foot
    other = _block_distance(along, side, x, shape[LOW1], shape[HIGH1], shape[THICK1], shape[WIDE1])  # the body
    if other < least:
        least = other
    return math.sqrt(least) - shape[RADIUS] - lag * t


@njit(cache=True)
def _meeting(rods, rod, qpos, qvel, ctrl, h, nearest, shape):
    """(met, start, end): the fractions of the step between the first and the last moment the rod's figure nearest
    to the ball comes within the ball's radius (and CONTACT_MARGIN) of it, the ball on its straight path and the rod
    turning and sliding at its drive's target. Conservative advancement: the gap closes no faster than the ball's
    speed plus the figure's, so a gap d is safe for d / that long. A drive not yet at its target (a jolt) may lag its
    path by the difference times the time."""
    b, bv = int(shape[BALL_QPOS]), int(shape[BALL_QVEL])
    px = qpos[b] - qpos[int(rods[rod, SLIDE_QPOS])] - nearest
    py, pz = qpos[b + 1] - rods[rod, Y], qpos[b + 2] - shape[AXIS_HEIGHT]
    vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
    angle, turn, slide = qpos[int(rods[rod, ROTATE_QPOS])], ctrl[int(rods[rod, ROTATE_CTRL])], ctrl[int(rods[rod, SLIDE_CTRL])]
    reach = shape[FIGURE_REACH]
    lag = abs(qvel[int(rods[rod, ROTATE_DOF])] - turn) * reach + abs(qvel[int(rods[rod, SLIDE_DOF])] - slide)  # m/s off the path
    closing = math.sqrt(vx * vx + vy * vy + vz * vz) + abs(turn) * reach + abs(slide) + lag
    if closing <= 0.0:  # a still ball, a still rod at its target: the gap stays what it is all step
        if _gap(0.0, angle, turn, px, py, pz, vx, vy, vz, slide, lag, shape) <= 1e-4:
            return True, 0.0, 1.0
        return False, 0.0, 0.0
    resolution = 1e-4 / (closing if closing > 1e-3 else 1e-3)  # s: a gap under 0.1 mm counts as met
    t = 0.0
    while True:
        d = _gap(t, angle, turn, px, py, pz, vx, vy, vz, slide, lag, shape)
        if d <= 1e-4:
            first = t
            break
        t += d / closing
        if t > h:
            return False, 0.0, 0.0
    t = h
    while t > first:
        d = _gap(t, angle, turn, px, py, pz, vx, vy, vz, slide, lag, shape)
        if d <= 1e-4:
            break
        step = d / closing
        t -= resolution if resolution > step else step
    return True, first / h, (first if first > t else t) / h


@njit(cache=True)
def _part(angle, now, target, h, ball_angle, closest, travel, shape):
    """(met, start, end): the fractions of the step in which the rod's figure can touch a ball seen at ball_angle and
    no nearer than `closest` to the axis (the sector test)."""
    foot_half = shape[FOOT_HALF]
    if closest <= foot_half:
        return True, 0.0, 1.0  # a ball at the rod itself: any angle (not met in play)
    wobble = travel / closest  # the most the ball's angle changes in the step
    head_half = shape[HEAD_HALF] / closest
    zones = 2 if closest <= shape[HEAD_REACH] else 1
    low = target if target < now else now  # rad/s: the rod's velocity stays between them (Python's min and max)
    high = target if target > now else now
    start, end = 1.0, 0.0
    for zone in range(zones):
        if zone == 0:
            centre, half = ball_angle, math.asin(foot_half / closest) + wobble
        else:
            centre, half = ball_angle + math.pi, math.asin(head_half if head_half < 1.0 else 1.0) + wobble
        if half >= math.pi:
            return True, 0.0, 1.0
        # The figure points at `angle + turned` after turning by `turned`; the zone is |turned - ahead| <= half, and
        # the same a turn ahead or behind (a wide zone of a fast ball near the axis may wrap round).
        ahead = _remainder(centre - angle, _TWO_PI)
        for turn in range(3):
            turns = -_TWO_PI if turn == 0 else (0.0 if turn == 1 else _TWO_PI)
            met, part_start, part_end = _zone_part(ahead + turns - half, ahead + turns + half, low, high, h)
            if met:
                if part_start < start:
                    start = part_start
                if part_end > end:
                    end = part_end
    if end >= start:
        return True, start, end
    return False, 0.0, 0.0


@njit(cache=True, inline="always")
def _zone_part(first, last, low, high, h):
    """(met, start, end): the fractions of the step in which the turn, from 0 at a rate within [low, high], lies in
    [first, last]."""
    if low >= 0.0 or high <= 0.0:
        # Turning one way (or still): the turn grows from 0 to at most `fastest` h, at least `slowest` h.
        if high > 0.0:
            fastest, slowest = high, low
        else:
            fastest, slowest = -low, -high
        if high <= 0.0:
            first, last = -last, -first
        if last < 0.0 or first > fastest * h:
            return False, 0.0, 0.0
        part_start = 0.0
        if fastest > _TINY:
            part_start = first / (fastest * h)
            if not part_start > 0.0:
                part_start = 0.0
        part_end = 1.0
        if slowest > _TINY:
            part_end = last / (slowest * h)
            if not part_end < 1.0:
                part_end = 1.0
        return True, part_start, part_end
    # Reversing within the step: the turn stays within [low h, high h].
    if last < low * h or first > high * h:
        return False, 0.0, 0.0
    return True, 0.0, 1.0


@njit(cache=True, inline="always")
def _remainder(x, y):
    """math.remainder(x, y) (IEEE 754: x - n y, n the integer nearest x / y, ties to even), exactly as CPython
    computes it (fmod is exact)."""
    absx, absy = abs(x), abs(y)
    m = np.fmod(absx, absy)
    c = absy - m
    if m < c:
        r = m
    elif m > c:
        r = -c
    else:
        r = m - 2.0 * np.fmod(0.5 * (absx - m), absy)
    return np.copysign(1.0, x) * r
