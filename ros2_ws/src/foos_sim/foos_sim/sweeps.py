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

The scan runs compiled before every fast step (foos_sim.sweep_scan: these rules' only code). window() gives the part
of the step in which a figure can touch the ball: only that part is cut into sub-steps
of FIGURE_STEP; before it and after it one sub-step each (nothing can touch there). After a sub-step with an
impact, foos_sim.simulation plans the rest of the step again.
"""
from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

# m of the figure's travel in one sub-step while it can touch the ball: the impacts were checked at up to 40 rad/s
# on the former servos (a foot's edge 6.2 mm a step); 3 mm kept the kicks within 5 % of the 20 kHz reference
# (docs/measurements/sim-2026-11-27-real-drives.md). Only the rotation counts: a slide at its 3.5 m/s moves 7 mm a
# step, as the former drives' figures did (4.3 m/s) without sub-steps.
FIGURE_STEP = 0.003
CONTACT_MARGIN = 0.001  # m added to the ball's radius: what a figure within it may touch
LEAST_FIGURE_SPEED = 0.5  # m/s a figure near the ball is taken to move at least (look-ahead gaps, foos_sim.impacts)


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


# The step as one, where no figure can touch the ball (the usual case: most steps the ball is beyond every foot's
# reach). Window is frozen: one instance serves every such step.
NO_WINDOW = Window(0.0, 1.0, 0.0, LEAST_FIGURE_SPEED)


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
        self.ball_qpos, self.ball_qvel = ball_qpos, ball_qvel
        # The same, packed for the compiled scan (foos_sim.sweep_scan's columns and entries, in their order).
        self._rods = np.array([[r.y, r.slide_dof, r.rotate_dof, r.slide_ctrl, r.rotate_ctrl, r.slide_qpos, r.rotate_qpos,
                                r.figures, r.spacing] for r in self.rods], dtype=float).reshape(len(self.rods), 9)
        self._rotate_dofs = [r.rotate_dof for r in self.rods]
        self._shape = np.array([ball_qpos, ball_qvel, *walls, self.floor, self.axis_height, self.foot_reach, self.foot_half,
                                self.head_half, self.head_reach, self.across, figure_reach, radius, *self.blocks[0],
                                *self.blocks[1], FIGURE_STEP, LEAST_FIGURE_SPEED], dtype=float)
        self._out = np.zeros(4 + len(self.rods))
        self._scan = None

    def window(self, qpos: np.ndarray, qvel: np.ndarray, ctrl: np.ndarray, h: float) -> Window:
        """The part of the next step of h in which a figure can touch the ball (MuJoCo's qpos, qvel and ctrl): the
        scan above, compiled (foos_sim.sweep_scan)."""
        if self._scan is None:
            # numba's import (about 0.5 s) only where a window is asked for: the jerk-limited drives
            from . import sweep_scan
            self._scan = sweep_scan.window
        found = self._scan(qpos, qvel, ctrl, h, self._rods, self._shape, self._out)
        if not found:
            return NO_WINDOW  # no figure can touch the ball in this step
        start, end, turning, speed = self._out[:4].tolist()
        flags = self._out[4:].tolist()
        return Window(start, end, turning, speed, frozenset(dof for dof, flag in zip(self._rotate_dofs, flags) if flag))
