"""Kicks and blocks at the drives' full speed: the scenes the fast physics is checked on against the reference.

kick() swings one home figure from a back-swing at rest into a still ball and reads the ball's speed as it
leaves the foot, with the foot's speed at contact. random_trial() is one of the random kicks and blocks of
the acceptance test and of `scripts/bench_sim --kicks N`: a random rod swung from a random back-swing,
already spinning, or held (a block), the ball placed in front of it rolling at up to 10 m/s, every other rod turned up or
hanging; it reports whether the ball stayed on the table, outside every figure, and finite.
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Optional

import mujoco
import numpy as np

from foos_core.names import BALL_BODY, COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS

from .simulation import TableSimulation

# Every figure laid flat, at rod height: clear of a ball on the field.
RODS_UP = np.array([math.pi / 2 if name.endswith("rotate") else 0.0 for name in JOINT_NAMES])
TRIAL_SECONDS = 0.25
CHECK_PERIOD = 0.001  # s between checks of a trial (one step on the fast physics)
# m a ball may overlap a figure at a check: the reference's springs overlap up to v / 6000 s (4 mm where a foot at
# 24 m/s meets it), far from the 28 mm of a ball through a foot.
FIGURE_OVERLAP = 0.006
# A trial's rod is held still (a block), swung from a back-swing at rest (a kick), or already spinning toward
# full speed (314 rad/s on the jerk-limited drives: a foot's edge at 24 m/s) when the ball arrives.
KINDS = ("block", "kick", "spin")
KIND_SHARES = (0.25, 0.4, 0.35)
PARKED = (0.3, 0.58)
OUT_OF_REACH = 0.1  # m from a rod's line: beyond its figures' reach (0.077 m) and the ball's radius


@dataclass(frozen=True)
class Kick:
    ball_speed: float  # m/s, planar, as the ball leaves the foot
    foot_speed: float  # m/s of the foot's face at the ball's centre height, as contact began
    rod_speed: float  # rad/s as contact began


def kick(sim: TableSimulation, back_swing_deg: float, rod: str = "attack", gap: float = 0.0065,
         figure_x: float = 0.0, run_up: float = 0.0) -> Optional[Kick]:
    """One full-speed kick of `rod` (home) from `back_swing_deg` behind hanging, at rest, into a still ball
    `gap` m in front of its hanging foot; the other figures laid flat. None if the foot never met the ball.

    With a `run_up` (s), the rod spins that long first with the ball parked, and the ball is put in place
    while the feet are up: the kick of a rod already at speed."""
    p = sim.params
    rotate = JOINT_NAMES.index(f"home_{rod}_rotate")
    joints = RODS_UP.copy()
    joints[rotate] = -math.radians(back_swing_deg)
    y_rod = float(p["rods"]["layout"][f"home_{rod}"]["y"])
    face = float(p["figure"]["foot_size"][1]) / 2
    ball = (figure_x, y_rod + face + sim.ball_radius + gap)
    sim.reset(PARKED if run_up else ball, (0.0, 0.0), joint_positions=joints)
    command = np.zeros(COMMAND_SIZE)
    command[rotate % COMMAND_SIZE] = sim.command_limits[rotate % COMMAND_SIZE]
    sim.set_command("home", command)
    if run_up:
        sim.advance(run_up)
        # The feet up (more than a quarter turn from hanging): clear of the ball's place in front of the rod.
        while abs(math.remainder(float(sim.joint_positions()[rotate]), 2 * math.pi)) < math.pi / 2 + 0.2:
            sim.advance(sim.timestep)
        sim.place_ball(ball)
    lever = math.hypot(float(p["rods"]["axis_height"]) - sim.ball_radius, face)
    period = max(sim.timestep, 0.00025)
    rod_speed = None
    for _ in range(round(0.3 / period)):
        sim.advance(period)
        if sim.figure_contacts()[0]:
            # The rod's velocity through the (sub-)step in which the touch began: one read before a 2 ms fast step
            # is its drive's setpoint at the middle of the step before (foos_sim.drives.FollowingDrives).
            rod_speed = float(sim.last_touch_joint_velocities("home")[rotate]) if rod_speed is None else rod_speed
        elif rod_speed is not None:
            return Kick(float(np.linalg.norm(sim.ball_velocity()[:2])), abs(rod_speed) * lever, rod_speed)
    return None


@dataclass(frozen=True)
class TrialResult:
    finite: bool
    on_table: bool  # inside the walls and under the cover (or scored through a mouth)
    deepest_figure_overlap: float  # m, the most the ball overlapped a figure of the swung rod at a check
    passed_through: bool  # the ball went from one side of a hanging foot to the other (through it)
    max_ball_speed: float  # m/s

    @property
    def ok(self) -> bool:
        return self.finite and self.on_table and not self.passed_through and self.deepest_figure_overlap <= FIGURE_OVERLAP


def _figure_geoms(sim: TableSimulation, rod: str) -> list[int]:
    return [g for g in range(sim.model.ngeom) if (sim.model.geom(g).name or "").startswith(f"{rod}_figure")]


def figure_overlap(sim: TableSimulation, geoms: list[int]) -> float:
    """m, the deepest the ball overlaps one of `geoms` now (0 when clear)."""
    ball = int(sim.model.body_geomadr[sim.model.body(BALL_BODY).id])
    fromto = np.zeros(6)
    deepest = 0.0
    for g in geoms:
        distance = mujoco.mj_geomDistance(sim.model, sim.data, ball, g, 0.01, fromto)
        deepest = max(deepest, -distance)
    return deepest


def _side_of_feet(sim: TableSimulation, rod: str, rotate: int, slide: int) -> Optional[float]:
    """Which side (+1, -1) of the rod's figures the ball is at its centre's height, when a foot's x span holds
    it and the figures reach 3 mm below its centre (a ball under a swung-back foot's tip passes it); else None."""
    layout = sim.params["rods"]["layout"][rod]
    angle = math.remainder(float(sim.joint_positions()[rotate]), 2 * math.pi)  # from hanging, in (-pi, pi]
    x, y, z = sim.ball_position().tolist()
    rods, figure = sim.params["rods"], sim.params["figure"]
    depth = float(rods["axis_height"]) - z  # of the ball's centre below the rod's axis
    if depth <= 0.0 or (float(rods["axis_height"]) - float(figure["foot_clearance"])) * math.cos(angle) < depth + 0.003:
        return None
    # Across the table: a foot's half width, or the body's where the figure meets the ball's height above the foot.
    along = depth / math.cos(angle)  # from the axis to the figure's point at the ball's height
    foot_top = float(rods["axis_height"]) - float(figure["foot_clearance"]) - float(figure["foot_size"][2])
    width = figure["foot_size"][0] if along >= foot_top else figure["body_size"][0]
    reach = float(width) / 2 + sim.ball_radius
    n = int(layout["figures"])
    centres = (np.arange(n) - (n - 1) / 2) * float(layout["spacing"]) + float(sim.joint_positions()[slide])
    if not np.any(np.abs(x - centres) < reach - 0.002):
        return None
    # A figure's mid-plane at the ball centre's height (it turns about the rod's axis; + swings toward +y).
    plane_y = float(layout["y"]) + depth * math.tan(angle)
    return math.copysign(1.0, y - plane_y)


def random_trial(sim: TableSimulation, rng: np.random.Generator) -> TrialResult:
    """A random kick or block (see the module docstring)."""
    team = int(rng.integers(len(TEAMS)))
    rod = RODS[int(rng.integers(len(RODS)))]
    name = f"{TEAMS[team]}_{rod}"
    rotate = JOINT_NAMES.index(f"{name}_rotate")
    slide = JOINT_NAMES.index(f"{name}_slide")
    layout = sim.params["rods"]["layout"][name]
    forward = 1.0 if team == 0 else -1.0  # home attacks +y
    joints = RODS_UP.copy()
    hanging = rng.random(len(JOINT_NAMES)) < 0.5
    joints[hanging & np.array([n.endswith("rotate") for n in JOINT_NAMES])] = 0.0
    joints[slide] = rng.uniform(-1, 1) * float(layout["travel"])
    kind = rng.choice(KINDS, p=KIND_SHARES)
    blocking = kind == "block"
    joints[rotate] = 0.0 if blocking else -forward * math.radians(rng.uniform(20.0, 180.0))
    # The ball within reach of the rod's figures, ahead of or behind it, rolling toward it at up to 10 m/s.
    y = float(layout["y"]) + rng.uniform(-0.09, 0.09)
    x = rng.uniform(-1, 1) * (sim.half_width - sim.ball_radius - 0.005)
    speed = rng.uniform(0.0, 10.0)
    heading = rng.uniform(-math.pi, math.pi)
    velocity = (speed * math.cos(heading), speed * math.sin(heading))
    # A spinning rod turns up to full speed first, the ball parked in a corner beyond the goalies' reach.
    sim.reset(PARKED if kind == "spin" else (x, y), (0.0, 0.0) if kind == "spin" else velocity, joint_positions=joints)
    for i, other in enumerate(TEAMS):
        command = np.zeros(COMMAND_SIZE)
        if i == team:
            command[rotate % COMMAND_SIZE] = forward * (0.0 if blocking else sim.command_limits[rotate % COMMAND_SIZE])
            command[slide % COMMAND_SIZE] = rng.uniform(-1, 1) * sim.command_limits[slide % COMMAND_SIZE]
        sim.set_command(other, command)
    if kind == "spin":
        # The ball comes to the spinning rod from beyond its figures' reach (teleported next to a foot turning at
        # 24 m/s it would be inside it a step later).
        sim.advance(rng.uniform(0.05, 0.3))
        side = rng.choice((-1.0, 1.0))
        if abs(float(layout["y"]) + side * (OUT_OF_REACH + 0.02)) > sim.half_length - sim.ball_radius:
            side = -side  # a goalie's: from the field's side
        vy = -side * abs(velocity[1]) if abs(velocity[1]) > 0.5 else -side * 0.5
        sim.place_ball((x, float(layout["y"]) + side * rng.uniform(OUT_OF_REACH, OUT_OF_REACH + 0.02)), (velocity[0], vy))
    elif not sim.ball_is_clear(1e-3):
        toward_centre = -math.copysign(1.0, float(layout["y"]))
        sim.place_ball((x, float(layout["y"]) + toward_centre * OUT_OF_REACH), velocity)  # clear of the rod's figures
    deepest, fastest, on_table, passed = 0.0, 0.0, True, False
    limit = np.array([sim.half_width, sim.half_length]) + 0.002
    geoms = _figure_geoms(sim, name)
    side = _side_of_feet(sim, name, rotate, slide)
    for _ in range(round(TRIAL_SECONDS / CHECK_PERIOD)):
        goal = sim.advance(CHECK_PERIOD)
        if not sim.state_is_finite():
            return TrialResult(False, False, math.inf, True, math.inf)
        position = sim.ball_position()
        if goal is None and (np.any(np.abs(position[:2]) > limit) or position[2] > float(sim.params["field"]["cover_height"])
                             or position[2] < 0.0):
            on_table = False
        if goal is not None:
            break
        deepest = max(deepest, figure_overlap(sim, geoms))
        fastest = max(fastest, float(np.linalg.norm(sim.ball_velocity())))
        now = _side_of_feet(sim, name, rotate, slide)
        # From one side of a hanging foot to the other between two checks: through it.
        passed |= now is not None and side is not None and now != side
        side = now
    return TrialResult(True, on_table, deepest, passed, fastest)
