"""Which fast steps a turning figure can strike the ball in, and when within the step (the fast physics' sub-steps).

A fast step is 2 ms; a foot at the jerk-limited drives' 314 rad/s moves 48 mm in it. The impacts
(foos_sim.impacts) see a figure point move in a straight line through a step, so a step in which a fast figure
can meet the ball is taken in sub-steps of at most FIGURE_STEP of the figure's travel (foos_sim.simulation).
This module decides where that is needed, from the figures' shape (the regulation figure: a foot block, and a
body from the foot up through the rod to the head; foos_sim.model_builder). A rod is looked at only when the
ball can come within a foot's reach of its axis in the step (a ball on the field stays axis_height - r below
the axes: no head reaches it, 0.041 m + r = 0.059 < 0.0605) and within a figure's half-width plus r of the
nearest figure across the table. Then:

- On a straight path (the ball short of every wall, the cover and a landing within the step: free_box), the
  first and the last moment at which the figure's blocks come within r + CONTACT_MARGIN of the ball, the rod
  turning and sliding at its drive's target, by conservative advancement (_meeting): the gap closes no faster
  than the ball's speed plus the figure's, so a gap d is safe for d / that long.
- Otherwise, and for the other rods once a figure can strike the ball (it may bounce off it within the step and
  keep its speed but not its direction), the sector test (_part): in a rod's cross-section the foot side lies
  within a foot's half-thickness of the figure's centre line and the head side within the body's, so a ball at
  distance rho and angle phi can be touched only while the figure points within asin((half-thickness + r) / rho)
  of phi (or phi + pi), rho widened by the ball's travel in the step (and twice the striking figure's speed).
  The rod turns between its angle now and after a step at its velocity now or its drive's target.

window() gives the part of the step in which a figure can touch the ball: only that part is cut into sub-steps
of FIGURE_STEP; before it and after it one sub-step each (nothing can touch there). After a sub-step with an
impact, foos_sim.simulation plans the rest of the step again.
"""
from __future__ import annotations

import bisect
import math
from dataclasses import dataclass

# m of the figure's travel in one sub-step while it can touch the ball: the impacts were checked at up to 40 rad/s
# on the former servos (a foot's edge 6.2 mm a step); 3 mm kept the kicks within 5 % of the 20 kHz reference
# (docs/measurements/sim-2026-11-27-real-drives.md). Only the rotation counts: a slide at its 3.5 m/s moves 7 mm a
# step, as the former drives' figures did (4.3 m/s) without sub-steps.
FIGURE_STEP = 0.003
CONTACT_MARGIN = 0.001  # m added to the ball's radius: what a figure within it may touch
LEAST_FIGURE_SPEED = 0.5  # m/s a figure near the ball is taken to move at least (look-ahead gaps, foos_sim.impacts)
_TINY = 1e-9


def free_box(model, ball_radius: float) -> tuple[float, float, float]:
    """(|x|, |y|, z) limits of the ball's centre short of every wall and the cover (geoms named `wall*` and
    `cover`, boxes): the side walls bound x, the end walls and the goals' parts that stand in front of them (a goal's
    roof reaches 15 mm into the field) bound y, the cover z. Conservative: the nearest of each across the table."""
    x_limit, y_limit, z_limit = math.inf, math.inf, math.inf
    for g in range(model.ngeom):
        name = model.geom(g).name
        if not (name.startswith("wall") or name == "cover"):
            continue
        (px, py, pz), (sx, sy, sz) = model.geom_pos[g], model.geom_size[g]
        inner_x, inner_y = abs(px) - sx, abs(py) - sy
        if name == "cover":
            z_limit = min(z_limit, pz - sz)
        elif inner_x > inner_y:
            x_limit = min(x_limit, inner_x)
        else:
            y_limit = min(y_limit, inner_y)
    return float(x_limit - ball_radius), float(y_limit - ball_radius), float(z_limit - ball_radius)


@dataclass(frozen=True)
class RodIndex:
    """One rod's place and its slots in MuJoCo's arrays."""

    y: float
    slide_dof: int
    rotate_dof: int
    slide_ctrl: int
    rotate_ctrl: int
    slide_qpos: int
    rotate_qpos: int
    figures: int
    spacing: float


@dataclass(frozen=True)
class Window:
    """The part of a step [start, end] (fractions of it) in which a figure can touch the ball, the fastest such
    figure's rotation at its reach and its whole speed (m/s; the sub-steps and the impacts' look-ahead)."""

    start: float
    end: float
    turning: float
    figure_speed: float
    reachable: frozenset = frozenset()  # the rotation dofs of the rods that can touch the ball (foos_sim.impacts)

    def sub_steps(self, h: float) -> list[tuple[float, int, float]]:
        """The step of h as (length, count, figure speed) runs of sub-steps: one before the window and one after
        it (where no figure can touch the ball), and the window in sub-steps of at most FIGURE_STEP of travel;
        an edge shorter than such a sub-step joins the window. A single step when nothing moves that fast."""
        start, end = self.start, self.end
        if self.turning * h * (end - start) <= FIGURE_STEP:
            return [(h, 1, self.figure_speed)]
        fine = FIGURE_STEP / (self.turning * h)  # a sub-step's fraction of the step
        start = 0.0 if start < fine else start
        end = 1.0 if 1.0 - end < fine else end
        count = math.ceil((end - start) / fine)
        runs = [(h * start, 1, LEAST_FIGURE_SPEED)] if start > 0.0 else []
        runs.append((h * (end - start) / count, count, self.figure_speed))
        if end < 1.0:
            runs.append((h * (1.0 - end), 1, LEAST_FIGURE_SPEED))
        return runs


# The step as one, where no figure can touch the ball (Window is frozen: one instance serves every such step), and a
# scan that found no rod (the usual case: most steps the ball is beyond every foot's reach).
NO_WINDOW = Window(0.0, 1.0, 0.0, LEAST_FIGURE_SPEED)
_NO_SCAN = (Window(1.0, 0.0, 0.0, LEAST_FIGURE_SPEED), ())


class SweepTest:
    def __init__(self, params: dict, rods: list[RodIndex], figure_reach: float, ball_qpos: int, ball_qvel: int,
                 walls: tuple[float, float, float]):
        fig, rod_params = params["figure"], params["rods"]
        radius = float(params["ball"]["radius"]) + CONTACT_MARGIN
        foot_x, foot_y, _ = (float(v) for v in fig["foot_size"])
        body_x, body_y = (float(v) for v in fig["body_size"])
        foot_bottom = float(rod_params["axis_height"]) - float(fig["foot_clearance"])
        head = float(fig["head_height"])
        self.axis_height = float(rod_params["axis_height"])
        self.foot_half = foot_y / 2 + radius  # the foot side's half-thickness (the foot is the thicker part), plus r
        self.foot_reach = math.hypot(foot_bottom, foot_y / 2) + radius
        self.head_half = body_y / 2 + radius
        self.head_reach = math.hypot(head, body_y / 2) + radius
        self.across = max(foot_x, body_x) / 2 + radius
        self.figure_reach = figure_reach  # m, the farthest figure point from the axis (its speed)
        self.radius = radius
        # The figure's two blocks in its own frame: (along the figure from the axis: from, to; half-thickness;
        # half-width across the table).
        foot_top = foot_bottom - float(fig["foot_size"][2])
        self.blocks = ((foot_top, foot_bottom, foot_y / 2, foot_x / 2), (-head, foot_top, body_y / 2, body_x / 2))
        # |x|, |y| and z of the ball's centre beyond which it may meet a wall or the cover (free_box): a path that
        # gets there may bounce within the step. The floor: a falling ball that lands in the step.
        self.walls = walls
        self.floor = float(params["ball"]["radius"]) + CONTACT_MARGIN
        self.rods = sorted(rods, key=lambda r: r.y)
        self.ys = [r.y for r in self.rods]
        self.ball_qpos, self.ball_qvel = ball_qpos, ball_qvel

    def window(self, qpos: list, qvel: list, ctrl: list, h: float) -> Window:
        """The part of the next step of h in which a figure can touch the ball (qpos, qvel, ctrl as lists)."""
        b, bv = self.ball_qpos, self.ball_qvel
        bx, by, bz = qpos[b], qpos[b + 1], qpos[b + 2]
        vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
        # On a straight path through the step (no wall or cover reached) the figures' meeting times are found
        # exactly (_meeting); a path that bounces takes the sectors widened by the ball's travel (_part).
        wx, wy, wz = self.walls
        straight = (abs(bx + vx * h) < wx and abs(by + vy * h) < wy and bz + vz * h < wz
                    and (vz > -1e-3 or bz + vz * h > self.floor))
        window, striking = self._scan(qpos, qvel, ctrl, h, straight, 0.0, ())
        if striking:
            # The ball may bounce off a figure that can strike it and leave its straight path within the step: for the
            # other rods its travel then bounds where it goes (the sector test), in any direction, its speed raised by
            # at most twice the striking figure's until the step is planned again (after the sub-step of an impact, or
            # the step's end). Where another rod can touch it too, every rod takes the sector test.
            fine = window.turning * h * (window.end - window.start) > FIGURE_STEP
            extra = 2.0 * window.figure_speed * (FIGURE_STEP / window.turning if fine else h)
            window, more = self._scan(qpos, qvel, ctrl, h, straight, extra, striking)
            if set(more) - set(striking):
                window, _ = self._scan(qpos, qvel, ctrl, h, False, extra, ())
        if window.end < window.start:
            return NO_WINDOW  # no figure can touch the ball in this step
        return window

    def _scan(self, qpos: list, qvel: list, ctrl: list, h: float, straight: bool, extra: float,
              exempt: tuple) -> tuple[Window, tuple]:
        """The union of the rods' windows and the rods (indices) that have one. On a straight path each rod's meeting
        times (_meeting), or with `extra` travel the sector test for all but the `exempt` rods."""
        b, bv = self.ball_qpos, self.ball_qvel
        bx, by, bz = qpos[b], qpos[b + 1], qpos[b + 2]
        vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
        travel = math.sqrt(vx * vx + vy * vy + vz * vz) * h + extra
        # The ball's centre stays at least this far below the axes through the step (gravity only lowers it).
        below = self.axis_height - (bz + (vz if vz > 0.0 else 0.0) * h) - extra
        reach = self.foot_reach + travel
        rods, ys = self.rods, self.ys
        i = bisect.bisect_left(ys, by - reach)
        if i == len(ys) or ys[i] > by + reach:
            return _NO_SCAN  # no rod within a foot's reach along the table
        found = []
        speed, turning, start, end = LEAST_FIGURE_SPEED, 0.0, 1.0, 0.0  # no part yet: start > end
        while i < len(ys) and ys[i] <= by + reach:
            rod = rods[i]
            i += 1
            dy, dz = by - rod.y, bz - self.axis_height
            rho = math.sqrt(dy * dy + dz * dz)
            closest = rho - travel
            if below > closest:
                closest = below
            if closest > self.foot_reach:
                continue
            # Across the table: the ball within reach of the figure nearest to it (the rod slides in the step too).
            across = bx - qpos[rod.slide_qpos]
            middle = (rod.figures - 1) / 2  # figure k sits at (k - middle) * spacing from the rod's centre
            nearest = 0.0
            if rod.figures > 1:
                nearest = (min(max(round(across / rod.spacing + middle), 0), rod.figures - 1) - middle) * rod.spacing
            slide_now, slide_target = abs(qvel[rod.slide_dof]), abs(ctrl[rod.slide_ctrl])
            slide_speed = slide_target if slide_target > slide_now else slide_now
            if abs(across - nearest) > self.across + travel + slide_speed * h:
                continue
            now, target = qvel[rod.rotate_dof], ctrl[rod.rotate_ctrl]
            fastest = abs(target) if abs(target) > abs(now) else abs(now)
            if straight and (extra == 0.0 or i - 1 in exempt):
                part = self._meeting(rod, qpos, qvel, ctrl, h, nearest)
            else:
                part = self._part(qpos[rod.rotate_qpos], now, target, h, math.atan2(dy, -dz), closest, travel)
            if part is None:
                continue
            rim = fastest * self.figure_reach
            if rim > turning:
                turning = rim
            if slide_speed + rim > speed:
                speed = slide_speed + rim
            if part[0] < start:
                start = part[0]
            if part[1] > end:
                end = part[1]
            found.append(i - 1)
        if not found:
            return _NO_SCAN
        return Window(start, end, turning, speed, frozenset(rods[k].rotate_dof for k in found)), tuple(found)

    def _meeting(self, rod: RodIndex, qpos: list, qvel: list, ctrl: list, h: float, nearest: float) -> tuple[float, float] | None:
        """(start, end) fractions of the step between the first and the last moment the rod's figure nearest to the
        ball comes within the ball's radius (and CONTACT_MARGIN) of it, the ball on its straight path
        and the rod turning and sliding at its drive's target; None if it never does. Conservative advancement:
        the gap closes no faster than the ball's speed plus the figure's, so a gap d is safe for d / that long.
        A drive not yet at its target (a jolt) may lag its path by the difference times the time."""
        b, bv = self.ball_qpos, self.ball_qvel
        px, py, pz = qpos[b] - qpos[rod.slide_qpos] - nearest, qpos[b + 1] - rod.y, qpos[b + 2] - self.axis_height
        vx, vy, vz = qvel[bv], qvel[bv + 1], qvel[bv + 2]
        angle, turn, slide = qpos[rod.rotate_qpos], ctrl[rod.rotate_ctrl], ctrl[rod.slide_ctrl]
        reach = self.figure_reach
        lag = abs(qvel[rod.rotate_dof] - turn) * reach + abs(qvel[rod.slide_dof] - slide)  # m/s off the path
        closing = math.sqrt(vx * vx + vy * vy + vz * vz) + abs(turn) * reach + abs(slide) + lag
        touch = self.radius
        (low0, high0, thick0, wide0), (low1, high1, thick1, wide1) = self.blocks  # the foot, the body
        sin_, cos_, sqrt = math.sin, math.cos, math.sqrt

        def gap(t: float) -> float:
            theta = angle + turn * t
            sin, cos = sin_(theta), cos_(theta)
            y, z = py + vy * t, pz + vz * t
            along, side, x = y * sin - z * cos, abs(y * cos + z * sin), abs(px + (vx - slide) * t)
            ds = low0 - along if along < low0 else (along - high0 if along > high0 else 0.0)
            dl = side - thick0 if side > thick0 else 0.0
            dx = x - wide0 if x > wide0 else 0.0
            least = ds * ds + dl * dl + dx * dx
            ds = low1 - along if along < low1 else (along - high1 if along > high1 else 0.0)
            dl = side - thick1 if side > thick1 else 0.0
            dx = x - wide1 if x > wide1 else 0.0
            other = ds * ds + dl * dl + dx * dx
            if other < least:
                least = other
            return sqrt(least) - touch - lag * t

        if closing <= 0.0:  # a still ball, a still rod at its target: the gap stays what it is all step
            return (0.0, 1.0) if gap(0.0) <= 1e-4 else None
        resolution = 1e-4 / max(closing, 1e-3)  # s: a gap under 0.1 mm counts as met
        t = 0.0
        while True:
            d = gap(t)
            if d <= 1e-4:
                first = t
                break
            t += d / closing
            if t > h:
                return None
        t = h
        while t > first:
            d = gap(t)
            if d <= 1e-4:
                break
            t -= max(d / closing, resolution)
        return first / h, max(t, first) / h

    def _part(self, angle: float, now: float, target: float, h: float, ball_angle: float, closest: float,
              travel: float) -> tuple[float, float] | None:
        """(start, end) as fractions of the step in which the rod's figure can touch a ball seen at ball_angle
        and no nearer than `closest` to the axis, or None when it cannot."""
        if closest <= self.foot_half:
            return 0.0, 1.0  # a ball at the rod itself: any angle (not met in play)
        wobble = travel / closest  # the most the ball's angle changes in the step
        zones = [(ball_angle, math.asin(self.foot_half / closest) + wobble)]
        if closest <= self.head_reach:
            zones.append((ball_angle + math.pi, math.asin(min(1.0, self.head_half / closest)) + wobble))
        low, high = min(now, target), max(now, target)  # rad/s: the rod's velocity stays between them
        start, end = 1.0, 0.0
        for centre, half in zones:
            if half >= math.pi:
                return 0.0, 1.0
            # The figure points at `angle + turned` after turning by `turned`; the zone is |turned - ahead| <= half,
            # and the same a turn ahead or behind (a wide zone of a fast ball near the axis may wrap round).
            ahead = math.remainder(centre - angle, 2.0 * math.pi)
            for turns in (-2.0 * math.pi, 0.0, 2.0 * math.pi):
                part = self._zone_part(ahead + turns - half, ahead + turns + half, low, high, h)
                if part is not None:
                    start, end = min(start, part[0]), max(end, part[1])
        return (start, end) if end >= start else None

    @staticmethod
    def _zone_part(first: float, last: float, low: float, high: float, h: float) -> tuple[float, float] | None:
        """(start, end) fractions of the step in which the turn, from 0 at a rate within [low, high], lies in
        [first, last]; None if it never does."""
        if low >= 0.0 or high <= 0.0:
            # Turning one way (or still): the turn grows from 0 to at most `fastest` h, at least `slowest` h.
            fastest, slowest = (high, low) if high > 0.0 else (-low, -high)
            if high <= 0.0:
                first, last = -last, -first
            if last < 0.0 or first > fastest * h:
                return None
            part_start = max(0.0, first / (fastest * h)) if fastest > _TINY else 0.0
            part_end = min(1.0, last / (slowest * h)) if slowest > _TINY else 1.0
            return part_start, part_end
        # Reversing within the step: the turn stays within [low h, high h].
        if last < low * h or first > high * h:
            return None
        return 0.0, 1.0
