"""Shots for the synthetic camera: a ball struck at 3-8 m/s toward a goal, past the rods in its way, written as a
bag of /ball/state and /joint_states that `render_video --bag` films (the bench's shot cases).

Each shot: the ball is out of sight (picked up) for a while, rolls slowly up to a figure of the shooting rod (a pass,
or a ball brought under control), then is struck toward the far goal mouth (or a little wide of it, into the end
wall). The other rods hold still, each at a slide and an angle drawn per shot: hanging (the ball passes between the
figures or bounces off one), lifted (it rolls under their feet: from above, behind them) or level. The shot ends at
a goal, when the ball has slowed below 1 m/s, or after SHOT_LONGEST; the ball then lies still for TRAPPED_FOR unless
it scored. The states are the simulator's, sampled at SAMPLE_RATE: render_video --bag interpolates them to its
sub-frames, and while the ball is out of sight it is put below the floor, where the truth's `visible` is 0.

    python -m foos_sim.camera.shots OUT_BAG --duration 8 --seed 3
    render_video shots.mp4 --bag OUT_BAG --fps 25 --blur 12 --exposure 0.8 --ball-color yellow --visibility
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from foos_bag import BagError, BagWriter, write_ball_states, write_joint_states
from foos_core.command_line import run_cli
from foos_core.names import COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS
from foos_core.table_params import load_params
from foos_sim.simulation import TableSimulation

from .errors import RenderError
from .render import HIDDEN_Z

SHOT_SPEED = (3.0, 8.0)  # m/s
SAMPLE_RATE = 1000.0  # Hz: states written; at 8 m/s the ball moves 8 mm between two
HIDE_FOR, ROLL_FOR, SHOT_LONGEST = 0.25, 0.3, 0.5  # s: out of sight, rolling up to the strike, longest shot
ROLL_SPEED = (0.15, 0.25)  # m/s: the ball comes up to the shooting figure this fast, from up to 7.5 cm in front of it
SLOW = 1.0  # m/s: a shot this slow is over
MARGIN = 0.1  # s of states past the duration: the last frame's exposure reaches beyond its time
TRAPPED_FOR = 0.1  # s the ball of a shot that did not score lies still before it is picked up
# Angles a rod in the ball's way holds (rad): hanging; lifted, the feet 58 mm up, clear of the ball's top (35 mm);
# level. Drawn with equal odds.
ROD_ANGLES = (0.0, 1.3, -1.3, math.pi / 2, -math.pi / 2, 0.0)
HOLD_GAIN = 20.0  # 1/s: the drives' velocity command per unit of error, holding each rod where it was put


@dataclass
class ShotStates:
    t: np.ndarray  # (N,) s
    ball_position: np.ndarray  # (N, 3) m
    ball_velocity: np.ndarray  # (N, 3) m/s
    joint_position: np.ndarray  # (N, 16) JOINT_NAMES order
    speeds: list  # m/s of each shot at the strike


class _Recorder:
    def __init__(self):
        self.t, self.p, self.v, self.q = [], [], [], []

    def add(self, t: float, p, v, q) -> None:
        self.t.append(t)
        self.p.append(np.asarray(p, float))
        self.v.append(np.asarray(v, float))
        self.q.append(np.asarray(q, float))


def simulate_shots(duration: float, seed: int = 0, speed: tuple[float, float] = SHOT_SPEED,
                   params_file: str | None = None, hide_for: float = HIDE_FOR, roll_for: float = ROLL_FOR) -> ShotStates:
    """Shots one after another for `duration` seconds of states (and MARGIN more); hide_for and roll_for: seconds out
    of sight and rolling up to the shooting figure before each."""
    for name, value in (("--duration", duration), ("--hide-for", hide_for), ("--roll-for", roll_for)):
        if not (value > 0 and math.isfinite(value)):
            raise RenderError(f"{name} must be a positive number")
    if not (0 < speed[0] <= speed[1] and math.isfinite(speed[1])):
        raise RenderError("shot speeds must be positive, the lowest first")
    sim = TableSimulation(params=load_params(params_file))
    rng = np.random.default_rng(seed)
    layout = sim.params["rods"]["layout"]
    rods = [(team, rod) for team in TEAMS for rod in RODS]
    steps_per_sample = max(1, int(round(1.0 / (SAMPLE_RATE * sim.timestep))))
    dt = steps_per_sample * sim.timestep
    out = _Recorder()
    speeds = []
    t = 0.0
    end = duration + MARGIN
    while t < end:
        team = TEAMS[int(rng.integers(2))]
        direction = 1.0 if team == "home" else -1.0  # home attacks +y
        shooter = RODS[int(rng.integers(len(RODS)))]
        q = np.zeros(len(JOINT_NAMES))
        for i, (rod_team, rod) in enumerate(rods):
            travel = layout[f"{rod_team}_{rod}"]["travel"]
            q[2 * i] = rng.uniform(-0.9, 0.9) * travel
            if (rod_team, rod) != (team, shooter):
                q[2 * i + 1] = ROD_ANGLES[int(rng.integers(len(ROD_ANGLES)))]
        # The ball rests against the front of a shooting figure's foot.
        shooter_index = rods.index((team, shooter))
        rod = layout[f"{team}_{shooter}"]
        figures = np.arange(rod["figures"]) - (rod["figures"] - 1) / 2
        figure_x = q[2 * shooter_index] + rod["spacing"] * figures[int(rng.integers(len(figures)))]
        x = float(np.clip(figure_x + rng.uniform(-0.01, 0.01), -sim.half_width + 0.03, sim.half_width - 0.03))
        foot_half = sim.params["figure"]["foot_size"][1] / 2
        y = rod["y"] + direction * (foot_half + sim.ball_radius + 0.004)
        start = np.array([x, y, sim.ball_radius])
        sim.reset(ball_position=start, ball_velocity=(0.0, 0.0), joint_positions=q)
        q_now = sim.joint_positions()
        hidden = np.array([0.0, 0.0, HIDDEN_Z])
        for _ in range(int(round(hide_for / dt))):
            out.add(t, hidden, np.zeros(3), q_now)
            t += dt
        # It rolls up to the foot from in front of it, within 60 degrees of straight on (a kinematic roll: it is
        # short of the next rod's feet).
        angle = math.atan2(-direction, 0.0) + rng.uniform(-1.0, 1.0) * math.pi / 3
        roll = rng.uniform(*ROLL_SPEED) * np.array([math.cos(angle), math.sin(angle), 0.0])
        steps = max(1, int(round(roll_for / dt)))
        if abs(start[0] - roll[0] * steps * dt) > sim.half_width - sim.ball_radius:
            roll[0] = -roll[0]  # from the other side: not through the wall
        for i in range(steps):
            out.add(t, start - roll * (steps - i) * dt, roll, q_now)
            t += dt
        aim = np.array([rng.uniform(-1.5, 1.5) * sim.goal_half_width, direction * sim.half_length])
        heading = (aim - start[:2]) / np.linalg.norm(aim - start[:2])
        strike = float(rng.uniform(*speed))
        speeds.append(strike)
        sim.place_ball(start, strike * heading)
        shot_t, goal = 0.0, None
        while shot_t < SHOT_LONGEST and t < end:
            _hold(sim, q)
            goal = sim.step(steps_per_sample)
            shot_t += dt
            p, v = sim.ball_position(), sim.ball_velocity()
            out.add(t, p, v, sim.joint_positions())
            t += dt
            if goal is not None or (shot_t > 0.05 and np.linalg.norm(v[:2]) < SLOW) or p[2] < -0.05:
                break
        if goal is None:
            # A figure traps the ball before it is picked up: a ball taken out of sight while it moves leaves the
            # frame of that moment a streak for part of its exposure, whose truth says it is out of sight.
            p, q_now = sim.ball_position(), sim.joint_positions()
            for _ in range(int(round(TRAPPED_FOR / dt))):
                out.add(t, p, np.zeros(3), q_now)
                t += dt
    return ShotStates(np.array(out.t), np.array(out.p), np.array(out.v), np.array(out.q), speeds)


def _hold(sim: TableSimulation, target: np.ndarray) -> None:
    """Velocity commands that keep every rod at its target slide and angle (the figures are hit, and give)."""
    error = sim.joint_positions() - target
    for team_index, team in enumerate(TEAMS):
        half = slice(team_index * COMMAND_SIZE, (team_index + 1) * COMMAND_SIZE)
        sim.set_command(team, -HOLD_GAIN * error[half])


def write_shots_bag(path: str | Path, states: ShotStates) -> None:
    """The states as /ball/state and /joint_states (what render_video --bag replays)."""
    with BagWriter(path) as bag:
        write_ball_states(bag, states.t, states.ball_position, states.ball_velocity)
        write_joint_states(bag, states.t, JOINT_NAMES, states.joint_position, np.zeros_like(states.joint_position))


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="python -m foos_sim.camera.shots", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", help="the bag to write (a new directory)")
    p.add_argument("--duration", type=float, default=8.0, help="seconds of shots (default 8)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--min-speed", type=float, default=SHOT_SPEED[0], help="m/s (default 3)")
    p.add_argument("--max-speed", type=float, default=SHOT_SPEED[1], help="m/s (default 8)")
    p.add_argument("--params-file", help="table parameter file (default: the nominal table)")
    p.add_argument("--hide-for", type=float, default=HIDE_FOR, help=f"s out of sight before each shot (default {HIDE_FOR})")
    p.add_argument("--roll-for", type=float, default=ROLL_FOR,
                   help=f"s rolling up to the shooting figure before each shot (default {ROLL_FOR})")
    return p


def _main(args: argparse.Namespace) -> int:
    try:
        BagWriter.check_new_path(args.out)
        states = simulate_shots(args.duration, args.seed, (args.min_speed, args.max_speed), args.params_file,
                                args.hide_for, args.roll_for)
        write_shots_bag(args.out, states)
    except BagError as error:
        raise RenderError(str(error)) from None
    print(f"shots: {len(states.speeds)} shots at {min(states.speeds):.1f}-{max(states.speeds):.1f} m/s, "
          f"{states.t[-1]:.2f} s -> {args.out}")
    return 0


def main(argv=None) -> None:
    run_cli(build_parser(), _main, argv)


if __name__ == "__main__":
    main()
