"""What one shot can do against the scripted defence: the ceiling of the hardened task (ROS-free).

Two measurements on the table's own physics:

- `kick_table`: the full-swing kicks a home rod makes from hanging, by where the ball sits across the foot.
  The speed and direction a policy can give the ball come from these.
- `shot_outcomes`: the ball at rest in front of the home attack rod while the scripted away goalie and
  defence settle on it (as they do in a hardened episode), then launched at a given speed toward a point
  drawn uniformly in the goal mouth, the home outfield rods lifted out of its way. Each shot ends in a goal,
  an own goal (a rebound past the home goalie) or neither. The opponent can be made to react late: it then
  acts on the observation of `delay` seconds ago (tasks.ReactionDelay), as a real table's camera and drives would
  make it. Or the ball can first be carried along the line at a given speed, the away rods following it.

No single shot a policy can kick beats the rate measured here at the same speed and delay, so it bounds
what aiming alone can win; goals beyond it come from play over several touches.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Optional, Sequence

import numpy as np
from tqdm import tqdm

from foos_core.names import JOINT_NAMES, RODS
from foos_sim.simulation import TableSimulation

from .env import make_env
from .evaluation import wilson_interval
from .scripted import LIFTED  # rad, a rod turned horizontal, out of the ball's way

SHOT_LINE_AHEAD = 0.045   # m, the ball's start ahead of the home attack rod: where its kicks are fastest
SETTLE_STEPS = 20         # control steps (0.4 s) for the away rods to settle on the still ball
SHOT_STEPS = 100          # control steps (2 s) a shot is followed for
MOUTH_MARGIN = 0.08       # m, aim points are drawn within +-this of the goal's centre (the mouth is +-0.10)
CARRY_TIME = 0.2          # s, the longest a ball is carried along the line before a shot
CARRY_SPAN = 0.4          # m, the farthest it is carried (it starts 0.2 m off the centre line, on either side)


@dataclass(frozen=True)
class Kick:
    offset: float   # m, ball centre minus figure centre across the rod (x), at the kick
    speed: float    # m/s, ball speed after the kick (0: the foot missed it)
    angle: float    # degrees from straight ahead (+y), positive toward +x


def kick_table(offsets: Sequence[float], rod: str = "attack", ahead: float = SHOT_LINE_AHEAD,
               params_file: Optional[str] = None) -> list[Kick]:
    """Full-swing kicks of the home `rod`'s middle figure from hanging, the ball still `ahead` of the rod axis
    and `offset` across from the figure's centre; the ball's velocity once it has left the foot."""
    sim = TableSimulation(params_file)
    rod_y = float(sim.params["rods"]["layout"][f"home_{rod}"]["y"])
    slide = JOINT_NAMES.index(f"home_{rod}_slide")
    command = np.zeros(len(RODS) * 2)
    command[2 * RODS.index(rod) + 1] = sim.command_limits[2 * RODS.index(rod) + 1]  # full speed toward the away goal
    kicks = []
    for offset in offsets:
        joints = np.zeros(len(JOINT_NAMES))
        joints[slide] = -offset   # the middle figure (at slide 0, x 0) moves so the ball sits `offset` across it
        sim.reset(ball_position=(0.0, rod_y + ahead), joint_positions=joints)
        sim.set_command("home", command)
        for _ in range(30):        # 60 ms: a kick is over in under 30
            sim.advance(0.002)
            if sim.ball_position()[1] > rod_y + ahead + 0.03:
                break
        vx, vy = sim.ball_velocity()[:2]
        speed = float(np.hypot(vx, vy))
        kicks.append(Kick(float(offset), speed, float(np.degrees(np.arctan2(vx, vy))) if speed > 0.05 else 0.0))
    return kicks


def shot_outcomes(speed: float, delay: float, shots: int, seed: int, carry_speed: float = 0.0,
                  params_file: Optional[str] = None, progress: bool = False, opponent_view: str = "camera") -> dict:
    """Aimed shots from the home attack line against the settled scripted goalie and defence (module doc).

    With `carry_speed` > 0 the ball is first carried along the line, as a figure pinning it would move it:
    from one side toward the other at that speed for CARRY_TIME (or until it has crossed CARRY_SPAN), the
    away rods following it, and shot from where the carry ends."""
    env = make_env(reset="hardened", opponent="scripted", params_file=params_file, opponent_delay=delay, opponent_view=opponent_view)
    sim = env.sim
    layout = sim.params["rods"]["layout"]
    start_y = float(layout["home_attack"]["y"]) + SHOT_LINE_AHEAD
    goal_y = 0.5 * float(sim.params["field"]["length"])
    half_width = 0.5 * float(sim.params["field"]["width"]) - float(sim.params["ball"]["radius"]) - 0.02
    joints = np.zeros(len(JOINT_NAMES))
    for rod in ("defence", "midfield", "attack"):
        joints[JOINT_NAMES.index(f"home_{rod}_rotate")] = LIFTED
    hold = np.zeros(len(RODS) * 2)
    rng = np.random.default_rng(seed)
    goals = own_goals = 0
    label = f"{speed:g} m/s, {delay * 1e3:.0f} ms, carried at {carry_speed:g} m/s"
    for _ in tqdm(range(shots), desc=label, unit="shot", disable=not progress):
        env.reset(seed=int(rng.integers(2**31)))   # also forgets what a late opponent saw
        if carry_speed > 0:
            direction = rng.choice((-1.0, 1.0))
            x = -direction * 0.5 * CARRY_SPAN
        else:
            x = rng.uniform(-half_width, half_width)
        sim.reset(ball_position=(x, start_y), joint_positions=joints)
        for _ in range(SETTLE_STEPS):
            env.step(hold)
            sim.place_ball((x, start_y))   # held still while the away rods settle on it
        if carry_speed > 0:
            carry_steps = int(min(CARRY_TIME, CARRY_SPAN / carry_speed) / env.dt)
            for _ in range(rng.integers(1, carry_steps + 1)):   # the shot comes at a random point of the carry
                x += direction * carry_speed * env.dt
                env.step(hold)
                sim.place_ball((x, start_y), (direction * carry_speed, 0.0))
        aim = np.array([rng.uniform(-MOUTH_MARGIN, MOUTH_MARGIN) - x, goal_y - start_y])
        sim.place_ball((x, start_y), speed * aim / np.linalg.norm(aim))
        for _ in range(SHOT_STEPS):
            _, _, terminated, truncated, _ = env.step(hold)
            if terminated or truncated:
                break
        goals += env.stats.goal == "home"
        own_goals += env.stats.goal == "away"
    return {"speed": speed, "delay_s": env.opponent_delay_steps * env.dt, "opponent_view": opponent_view,
            "carry_speed": carry_speed, "shots": shots,
            "goal_rate": goals / shots, "goal_rate_ci95": list(wilson_interval(goals, shots)),
            "own_goal_rate": own_goals / shots, "own_goal_rate_ci95": list(wilson_interval(own_goals, shots))}
