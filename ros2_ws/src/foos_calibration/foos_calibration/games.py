"""Synthetic game recordings: both teams played by simple players on TableSimulation, written as a bag.

The players (this module's own; calibration may not use foos_policy) track the ball's x with the figure
nearest to it, kick when the ball is near their rod line, and add random excitation (full-speed bursts,
reversals, spins) so that every drive meets fast changes and its limits. The ball is kicked often and
served again when it stops, leaves the field or a goal is scored.

Hidden drive effects (`rod_latency`, `rod_speed_limit`, `rod_acceleration_limit`) are applied by this
generator's OWN command pipeline (HiddenDrives: a delay queue and limiters on what it sends, step by step,
to an ideal TableSimulation), not by foos_sim.drive_limits, the model calibration fits; on the jerk-limited
drives (params/robot_table.yaml) an acceleration limit is the drives' own generators' (_with_generator_acceleration). Hidden table
effects (TABLE_EFFECTS) are forces on the ball from the same loop (hidden_forces, as the free-roll
generator's). A hidden `camera_latency` stamps every detection `delay` after its capture (the encoders keep
the true clock). A hidden `figure_restitution` (`coefficient`) is the generating table's own `figures:
restitution`: it is hidden INSIDE the model being fitted (the fast physics' figure impact rule), as no
outside mechanism can bounce the ball off a figure. The bag records the commands as the players sent them, as a real recorder would:

  /ball/detection   geometry_msgs/PointStamped at the camera rate, Gaussian noise, dropouts
  /joint_states     the 16 joints at the encoder rate, stamped at measurement, with encoder noise
  /home/rods/command, /away/rods/command   std_msgs/Float64MultiArray, stamped on arrival (when sent)

    ros2 run foos_calibration generate_measured OUT --game --duration 60 --effect rod_latency:delay=0.03
"""
from __future__ import annotations

import argparse
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Sequence

import numpy as np

from foos_bag import FLOAT64_MULTI_ARRAY, BagWriter, typestore, write_ball_detections, write_joint_states
from foos_core.names import AXES, COMMAND_SIZE, JOINT_NAMES, RODS, TEAMS, command_topic
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.drive_profiles import drive_kind
from foos_sim.effects import EffectError
from foos_sim.simulation import TableSimulation

from .hidden_forces import BallBody, HiddenEffects, ball_wrench

DRIVE_EFFECTS = ("rod_latency", "rod_speed_limit", "rod_acceleration_limit")
# Table effects a game can hide (forces on the ball). Not wall_restitution: the free-roll generator changes
# bounces at the walls it knows, the game's fast physics resolves them in foos_sim.impacts.
TABLE_EFFECTS = ("table_tilt", "rolling_resistance", "viscous_damping", "air_drag", "surface_dent")
# The camera's latency is hidden in the stamps alone: a detection is stamped `delay` after its capture.
CAMERA_EFFECTS = ("camera_latency",)
FIGURE_EFFECTS = ("figure_restitution",)
FIGURE_RESTITUTION_RANGE = (0.05, 0.95)  # the coefficient's range the replays' grid can fit (figure_bounces.GRID is 0.15-0.95)
MAX_CAMERA_DELAY = 0.5  # s
CONTROL_PERIOD = 0.02  # s: the players send commands at 50 Hz, as the RL env and policy_node do
KICK_REACH = 0.07  # m: a player kicks when the ball centre is this close to its rod line
KICK_TIME = 0.08  # s of full-speed rotation per kick
# How fast the players move a rod (slide m/s, rotation rad/s), whatever the drives allow: a person's kick, not a
# robot's. These are the former servo table's limits, so on that table the players command what they always did.
# At the robot's 314 rad/s the same players spin four turns a kick and score every 1.5-2 s (34-41 goals in 60 s,
# seeds 1-5, against 6-14 with this cap and 4-12 on the servo table: docs/measurements/sim-2026-11-29-robot-default.md),
# leaving calibration few free rolls. The drive effects they are tested on (random_drive_effect) lie below these speeds.
PLAYER_SPEED_LIMITS = (3.0, 40.0)
REST_SPEED = 0.04  # m/s: a ball slower than this for REST_TIME is served again
REST_TIME = 0.6


class GameError(ValueError):
    """A game that cannot be generated (bad effect, bad option)."""


@dataclass
class GameOptions:
    duration: float = 60.0  # s of game
    seed: int = 0
    fps: float = 120.0  # camera frames per second
    noise: float = 0.0015  # m, detection noise std
    dropout: float = 0.05  # probability a frame has no detection
    encoder_rate: float = 250.0  # Hz, /joint_states
    slide_noise: float = 0.0002  # m, encoder position noise of a slide
    rotate_noise: float = 0.003  # rad
    slide_velocity_noise: float = 0.02  # m/s, of the velocity the encoders report
    rotate_velocity_noise: float = 0.3  # rad/s
    excitation: float = 0.35  # share of control periods in which a rod starts a random burst
    camera_only: bool = False  # write /ball/detection alone: a game filmed from above, no encoders, no commands


@dataclass
class GameRecording:
    ball_t: np.ndarray
    ball_position: np.ndarray  # (N, 3)
    joint_t: np.ndarray
    joint_position: np.ndarray  # (M, 16), JOINT_NAMES order
    joint_velocity: np.ndarray
    command_t: np.ndarray  # (K,) send (= arrival) times, the same for both teams
    commands: dict[str, np.ndarray]  # team -> (K, 8)
    serves: int = 0
    goals: list[str] = field(default_factory=list)
    touches: tuple[int, int] = (0, 0)
    style: dict | None = None  # game_styles.GameStyle.as_dict() of a styled game
    camera_only: bool = False  # its bag holds the camera's detections alone


def _selects(params: dict, team: str, rod: str, axis: str) -> bool:
    return params.get("team", team) == team and params.get("rod", rod) == rod and params.get("axis", axis) == axis


class HiddenDrives:
    """The generator's own drive pipeline: what the players send, delayed, speed-clipped and rate-limited.

    Written apart from foos_sim.drive_limits on purpose (a found effect must not be the code agreeing with
    itself): plain per-drive Python, a queue of sent commands per team, the limits looked up per drive.
    """

    def __init__(self, effects: Sequence[dict], command_limits: np.ndarray):
        self.delay = [0.0] * len(JOINT_NAMES)
        self.speed = [float(c) for c in np.tile(command_limits, len(TEAMS))]
        self.accel = [math.inf] * len(JOINT_NAMES)
        # Narrower selections (more of team/rod/axis given) override wider ones, as the contract reads.
        for effect in sorted(effects, key=lambda e: sum(k in (e.get("params") or {}) for k in ("team", "rod", "axis"))):
            name, params = effect.get("name"), dict(effect.get("params") or {})
            if name not in DRIVE_EFFECTS:
                continue  # a table effect: hidden_forces carries it
            for key, allowed in (("team", TEAMS), ("rod", RODS), ("axis", AXES)):
                if key in params and params[key] not in allowed:
                    raise GameError(f"effect `{name}`: `{key}` must be one of {', '.join(allowed)}")
            for j, joint in enumerate(JOINT_NAMES):
                team, rod, axis = joint.split("_")
                if name == "rod_latency":
                    if "delay" not in params:
                        raise GameError("effect `rod_latency` needs `delay`")
                    if _selects(params, team, rod, axis):
                        self.delay[j] = float(params["delay"])
                elif _selects({k: v for k, v in params.items() if k != "axis"}, team, rod, axis) and axis in params:
                    value = float(params[axis])
                    if name == "rod_speed_limit":
                        self.speed[j] = min(float(command_limits[j % COMMAND_SIZE]), value)
                    else:
                        self.accel[j] = value
        if any(not (0 <= d <= 1.0) for d in self.delay) or any(not (v > 0) for v in self.speed + self.accel):
            raise GameError("drive effects need a delay in [0, 1] s and positive limits")
        self.queue: list[list[tuple[float, list[float]]]] = [[(-math.inf, [0.0] * COMMAND_SIZE)] for _ in TEAMS]
        self.target = [0.0] * len(JOINT_NAMES)

    def send(self, time: float, team: int, command: Sequence[float]) -> None:
        self.queue[team].append((time, [float(c) for c in command]))
        horizon = time - max(self.delay) - 1.0
        while len(self.queue[team]) > 2 and self.queue[team][1][0] < horizon:
            self.queue[team].pop(0)

    def _acting(self, team: int, i: int, j: int, time: float) -> float:
        """The command drive j (command index i of `team`) acts on at `time`: the last sent `delay` before."""
        acting = 0.0
        for sent, command in self.queue[team]:
            if sent <= time - self.delay[j] + 1e-9:
                acting = command[i]
            else:
                break
        return acting

    def step(self, time: float, dt: float) -> list[list[float]]:
        """The commands the ideal drives get for the step [time, time + dt), per team."""
        out = []
        for team in range(len(TEAMS)):
            row = []
            for i in range(COMMAND_SIZE):
                j = team * COMMAND_SIZE + i
                goal = max(-self.speed[j], min(self.speed[j], self._acting(team, i, j, time)))
                change = max(-self.accel[j] * dt, min(self.accel[j] * dt, goal - self.target[j]))
                self.target[j] += change
                row.append(self.target[j])
            out.append(row)
        return out

    def changes(self, time: float, dt: float) -> list[tuple[float, int, list[float]]]:
        """(arrival, team, command) for the step [time, time + dt): each team's at its start (step()), and again at
        each instant within it when a command falls due on a drive without an acceleration limit, which a real
        drive acts on then, not at the next physics step (TableSimulation.set_command's `at`). A rate-limited
        drive keeps its step's target."""
        rows = self.step(time, dt)
        out = [(time, team, row) for team, row in enumerate(rows)]
        for team, row in enumerate(rows):
            free = [(i, team * COMMAND_SIZE + i) for i in range(COMMAND_SIZE) if math.isinf(self.accel[team * COMMAND_SIZE + i])]
            due = sorted({sent + self.delay[j] for sent, _ in self.queue[team] for _, j in free
                          if time + 1e-9 < sent + self.delay[j] < time + dt - 1e-9})
            for instant in due:
                row = list(row)
                for i, j in free:
                    row[i] = max(-self.speed[j], min(self.speed[j], self._acting(team, i, j, instant)))
                out.append((instant, team, row))
        return out


def player_limits(command_limits: np.ndarray) -> np.ndarray:
    """What a player commands at most on drives with these limits (a team's 8): PLAYER_SPEED_LIMITS or the drives'."""
    return np.minimum(np.asarray(command_limits, dtype=float), np.tile(PLAYER_SPEED_LIMITS, len(RODS)))


class Player:
    """One team's rods: track the ball's x, kick near the rod line, random bursts and spins."""

    def __init__(self, team: str, params: dict, limits: np.ndarray, rng: np.random.Generator, excitation: float):
        self.team, self.rng, self.limits, self.excitation = team, rng, limits, excitation
        layout = params["rods"]["layout"]
        self.rods = [layout[f"{team}_{rod}"] for rod in RODS]
        self.kick_sign = 1.0 if team == "home" else -1.0  # home attacks +y: its feet swing toward +y
        self.kick_until = [-1.0] * len(RODS)
        self.burst_until = [-1.0] * COMMAND_SIZE
        self.burst_value = [0.0] * COMMAND_SIZE
        self.period = CONTROL_PERIOD  # s between commands (a style may send faster)

    def command(self, time: float, ball: np.ndarray, joints: np.ndarray) -> np.ndarray:
        out = np.zeros(COMMAND_SIZE)
        for r, rod in enumerate(self.rods):
            slide, angle = joints[2 * r], joints[2 * r + 1]
            # Slide: the figure nearest to the ball's x goes under it.
            n, spacing = int(rod["figures"]), float(rod["spacing"])
            offsets = (np.arange(n) - (n - 1) / 2) * spacing
            wanted = np.clip(ball[0] - offsets, -rod["travel"], rod["travel"])
            target = wanted[np.argmin(np.abs(wanted - slide))]
            out[2 * r] = 25.0 * (target - slide)
            # Rotate: kick when the ball is near the line, else hang (nearest multiple of 2 pi).
            if abs(ball[1] - rod["y"]) < KICK_REACH and time > self.kick_until[r] + 0.15:
                self.kick_until[r] = time + KICK_TIME * self.rng.uniform(0.6, 1.2)
            if time < self.kick_until[r]:
                out[2 * r + 1] = self.kick_sign * self.limits[2 * r + 1]
            else:
                hang = 2 * math.pi * round(angle / (2 * math.pi))
                out[2 * r + 1] = 30.0 * (hang - angle)
            for axis in (2 * r, 2 * r + 1):
                if time >= self.burst_until[axis] and self.rng.random() < self.excitation * self.period / 0.1:
                    # Bursts of 40-100 % of the limit, either way, for 0.06-0.3 s: reversals and top speed.
                    self.burst_until[axis] = time + self.rng.uniform(0.06, 0.3)
                    self.burst_value[axis] = self.rng.choice((-1.0, 1.0)) * self.rng.uniform(0.4, 1.0) * self.limits[axis]
                if time < self.burst_until[axis]:
                    out[axis] = self.burst_value[axis]
        # A slide burst against its stop would only push the stop: turn it back.
        for r, rod in enumerate(self.rods):
            slide = joints[2 * r]
            if abs(slide) > rod["travel"] - 0.01 and out[2 * r] * slide > 0:
                out[2 * r] = -out[2 * r]
                self.burst_value[2 * r] = -self.burst_value[2 * r]
        return np.clip(out, -self.limits, self.limits)


def _serve(sim: TableSimulation, rng: np.random.Generator) -> None:
    for _ in range(100):
        x, y = rng.uniform(-0.25, 0.25), rng.uniform(-0.5, 0.5)
        speed, heading = rng.uniform(0.5, 3.0), rng.uniform(-math.pi, math.pi)
        sim.place_ball((x, y), (speed * math.cos(heading), speed * math.sin(heading)))
        if sim.ball_is_clear():
            return


def play(effects: Sequence[dict], options: GameOptions = GameOptions(), params: dict | None = None,
         style=None) -> GameRecording:
    """A game of `options.duration` s on an ideal (fast-physics) table.

    The hidden drive effects are applied by HiddenDrives, the table effects (TABLE_EFFECTS) by forces on
    the ball from this loop (hidden_forces), both outside the model that `calibrate` fits. A `style`
    (game_styles.GameStyle) changes how the players play, how often they send and when their commands arrive
    and are stamped, and what the camera and encoders lose.
    """
    hideable = DRIVE_EFFECTS + TABLE_EFFECTS + CAMERA_EFFECTS + FIGURE_EFFECTS
    unknown = [e.get("name") for e in effects if e.get("name") not in hideable]
    if unknown:
        raise GameError(f"the game generator hides {', '.join(hideable)}; not `{unknown[0]}`")
    camera_delay = _camera_delay(effects)
    try:
        table = HiddenEffects.from_effects([e for e in effects if e.get("name") in TABLE_EFFECTS])
    except EffectError as error:
        raise GameError(str(error)) from None
    rng = np.random.default_rng(options.seed)
    params = params if params is not None else load_params()
    params = {**params, "effects": [e for e in params.get("effects", []) or [] if e.get("name") not in DRIVE_EFFECTS]}
    params = _with_figure_restitution(params, effects)
    in_generators = drive_kind(params) == "jerk_limited"
    if in_generators:
        params = _with_generator_acceleration(params, effects)
    sim = TableSimulation(params=params)
    hidden = HiddenDrives([e for e in effects if not (in_generators and e.get("name") == "rod_acceleration_limit")],
                          sim.command_limits)
    pushed = _BallPush(sim, params, table) if effects and any(e.get("name") in TABLE_EFFECTS for e in effects) else None
    players = [Player(team, params, player_limits(sim.command_limits), rng, options.excitation) for team in TEAMS]
    if style is not None:
        players = [style.player(team, player, rng) for team, player in zip(TEAMS, players)]
    sim.reset()
    _serve(sim, rng)
    dt = sim.timestep
    per_control = max(1, round((style.control_period if style is not None else CONTROL_PERIOD) / dt))
    steps = int(round(options.duration / dt))
    ball_t, ball_p, joint_p, joint_v, command_t = [], [], [], [], []
    commands = {team: [] for team in TEAMS}
    rest_since, serves, goals = None, 1, []
    for k in range(steps):
        time = sim.time
        if k % per_control == 0:
            ball, joints = sim.ball_position(), sim.joint_positions()
            arrival = time + (style.transport(rng) if style is not None else 0.0)  # the drives act on it from then
            command_t.append(arrival if style is None or style.stamps == "arrival" else time)
            for t_index, (team, player) in enumerate(zip(TEAMS, players)):
                sent = player.command(time, ball, joints[t_index * COMMAND_SIZE:(t_index + 1) * COMMAND_SIZE])
                commands[team].append(sent)
                hidden.send(arrival, t_index, sent)
        # The jerk-limited drives act on a command at its arrival, within the physics step. The servo table's still
        # get it at the step's start: calibration's servo model (foos_sim.drive_limits.predict_positions) steps its
        # commands on the 2 ms grid: against drives acting at the arrival its rotation errors rose from 0.9-1.7x the
        # encoder noise to 2.0-8.5x (docs/measurements/sim-2026-11-27-command-arrival.md). Until it splits its step
        # where a command falls due, as its S-curve branch does.
        changes = hidden.changes(time, dt) if in_generators else [(time, t, row) for t, row in enumerate(hidden.step(time, dt))]
        for arrival, t_index, row in changes:
            sim.set_command(TEAMS[t_index], row, at=arrival)
        if pushed is not None:
            pushed.apply()
        goal = sim.step(1)
        ball_t.append(sim.time)
        ball_p.append(sim.ball_position())
        joint_p.append(sim.joint_positions())
        joint_v.append(sim.joint_velocities())
        slow = np.hypot(*sim.ball_velocity()[:2]) < REST_SPEED
        rest_since = (rest_since if rest_since is not None else sim.time) if slow else None
        if goal or not sim.ball_on_field() or (rest_since is not None and sim.time - rest_since > REST_TIME):
            if goal:
                goals.append(goal)
            _serve(sim, rng)
            serves += 1
            rest_since = None
    recording = _measure(options, rng, sim, camera_delay, np.array(ball_t), np.array(ball_p), np.array(joint_p),
                         np.array(joint_v), np.array(command_t), {t: np.array(v) for t, v in commands.items()}, serves, goals)
    if style is not None:
        recording = style.measure(recording, params, rng)
        recording.style = style.as_dict()
    return recording


class _BallPush:
    """The hidden table effects as a force and torque on the ball, set before every physics step."""

    def __init__(self, sim: TableSimulation, params: dict, hidden: HiddenEffects):
        self.sim, self.hidden = sim, hidden
        geometry = TableGeometry.from_params(params)
        self.ball = BallBody(float(params["ball"]["mass"]), geometry.ball_radius, float(params["gravity"]),
                             float(params["ball"]["rolling_deceleration"]), (geometry.half_width, geometry.half_length))
        self.body = sim.model.body("ball").id

    def apply(self) -> None:
        sim = self.sim
        sim.data.xfrc_applied[self.body] = ball_wrench(self.hidden, self.ball, sim.ball_position(), sim.ball_velocity(),
                                                       sim.ball_angular_velocity())


def _hidden_value(effects: Sequence[dict], name: str, key: str, low: float, high: float, unit: str = "") -> float | None:
    """The `key` of the one hidden effect `name` (checked to lie in [low, high]), None without one."""
    values = []
    for effect in effects:
        if effect.get("name") == name:
            value = (effect.get("params") or {}).get(key)
            if not isinstance(value, (int, float)) or not (low <= value <= high):
                raise GameError(f"effect `{name}` needs `{key}` in [{low}, {high}]{unit}")
            values.append(float(value))
    if len(values) > 1:
        raise GameError(f"one `{name}` at most")
    return values[0] if values else None


def _camera_delay(effects: Sequence[dict]) -> float:
    """s: the hidden camera latency (camera_latency's `delay`), 0 without one."""
    delay = _hidden_value(effects, CAMERA_EFFECTS[0], "delay", 0, MAX_CAMERA_DELAY, " s")
    return delay if delay is not None else 0.0


def _with_generator_acceleration(params: dict, effects: Sequence[dict]) -> dict:
    """`params` with the hidden `rod_acceleration_limit` effects as the jerk-limited drives' own (a copy).

    On these drives the effect is the drive's trajectory generator planning within a lower acceleration (a robot
    drive's configured limit): a rate limiter ahead of the generator is not that, as the generator's S-curve, jerk
    limited, trails a ramp that reverses at once (11 ms at 800 rad/s^2; the rods then moved up to 25 rad/s off the
    effect's meaning). So it is hidden INSIDE the table being fitted, as a figure restitution is: TableSimulation's
    generators (foos_sim.drive_profiles) plan within it; the dead time and the speed limit stay in HiddenDrives."""
    accelerations = [e for e in effects if e.get("name") == "rod_acceleration_limit"]
    if not accelerations:
        return params
    return {**params, "effects": list(params.get("effects") or []) + [dict(e) for e in accelerations]}


def _with_figure_restitution(params: dict, effects: Sequence[dict]) -> dict:
    """`params` with the figures' restitution set to a hidden figure_restitution's `coefficient` (a copy)."""
    coefficient = _hidden_value(effects, FIGURE_EFFECTS[0], "coefficient", *FIGURE_RESTITUTION_RANGE)
    if coefficient is None:
        return params
    return {**params, "figures": {**params["figures"], "restitution": coefficient}}


def _measure(options, rng, sim, camera_delay, t, ball, joint_p, joint_v, command_t, commands, serves, goals) -> GameRecording:
    """Camera frames and encoder samples from the per-step truth."""
    frames = np.arange(t[0], t[-1], 1.0 / options.fps)
    index = np.clip(np.searchsorted(t, frames), 0, len(t) - 1)  # the state at the end of the step a frame falls in
    on_field = (np.abs(ball[index, 1]) <= sim.half_length) & (np.abs(ball[index, 0]) <= sim.half_width)
    seen = on_field & (rng.random(len(frames)) >= options.dropout)
    detections = ball[index[seen]].copy()
    detections[:, :2] += rng.normal(0.0, options.noise, size=(len(detections), 2))
    detections[:, 2] = sim.ball_radius  # a camera tracker reports the ball-centre plane
    every = 1.0 / (options.encoder_rate * sim.timestep)
    if abs(every - round(every)) < 1e-6:  # a whole number of physics steps between samples
        pick = np.arange(max(1, round(every)) - 1, len(t), max(1, round(every)))
        joint_t, joint_p, joint_v = t[pick], joint_p[pick], joint_v[pick]
    else:  # any other rate (above the physics rate too): the truth between steps, interpolated
        joint_t = np.arange(t[0] + 1.0 / options.encoder_rate, t[-1], 1.0 / options.encoder_rate)
        joint_p = np.stack([np.interp(joint_t, t, column) for column in joint_p.T], axis=1)
        joint_v = np.stack([np.interp(joint_t, t, column) for column in joint_v.T], axis=1)
    slide = np.array([name.endswith("_slide") for name in JOINT_NAMES])
    position = joint_p + rng.normal(size=(len(joint_t), len(JOINT_NAMES))) * np.where(
        slide, options.slide_noise, options.rotate_noise)
    velocity = joint_v + rng.normal(size=(len(joint_t), len(JOINT_NAMES))) * np.where(
        slide, options.slide_velocity_noise, options.rotate_velocity_noise)
    # A camera latency: the stamp is later than the capture (the encoders' stamps stay the reference clock).
    return GameRecording(frames[seen] + camera_delay, detections, joint_t, position, velocity, command_t, commands, serves, goals,
                         sim.figure_touches(), camera_only=options.camera_only)


def write_game_bag(recording: GameRecording, path: str | Path) -> None:
    store = typestore()
    array, layout = store.types[FLOAT64_MULTI_ARRAY], store.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
    with BagWriter(path) as writer:
        write_ball_detections(writer, recording.ball_t, recording.ball_position)
        if recording.camera_only:
            return
        write_joint_states(writer, recording.joint_t, JOINT_NAMES, recording.joint_position, recording.joint_velocity)
        for team in TEAMS:
            topic = command_topic(team)
            writer.add_topic(topic, FLOAT64_MULTI_ARRAY)
            for t, values in zip(recording.command_t.tolist(), recording.commands[team]):
                writer.write(topic, int(round(t * 1e9)), array(layout=layout, data=np.asarray(values, dtype=np.float64)))


def random_drive_effect(name: str, rng: np.random.Generator, team: str | None = None, rod: str | None = None) -> dict:
    """A drive effect with a magnitude in the ranges the rod identification is tested on."""
    where = {k: v for k, v in (("team", team), ("rod", rod)) if v is not None}
    if name == "rod_latency":
        return {"name": name, "params": {"delay": float(rng.uniform(0.015, 0.08)), **where}}
    if name == "rod_speed_limit":
        return {"name": name, "params": {"slide": float(rng.uniform(1.0, 2.2)), "rotate": float(rng.uniform(12.0, 30.0)), **where}}
    if name == "rod_acceleration_limit":
        return {"name": name, "params": {"slide": float(rng.uniform(15.0, 60.0)), "rotate": float(rng.uniform(300.0, 1500.0)), **where}}
    raise GameError(f"unknown drive effect `{name}`")


def random_camera_latency(rng: np.random.Generator) -> dict:
    """A camera latency like a real camera's: 10-20 ms for a machine-vision camera, 30-100 ms for a USB webcam."""
    return {"name": "camera_latency", "params": {"delay": float(rng.uniform(0.01, 0.1))}}


def random_figure_restitution(rng: np.random.Generator) -> dict:
    """A figure restitution from dead (0.2: soft plastic figures) to lively (0.85: hard figures), the nominal 0.5 inside."""
    return {"name": "figure_restitution", "params": {"coefficient": float(rng.uniform(0.2, 0.85))}}


def generate_game(path: str | Path, effects: Sequence[dict], options: GameOptions = GameOptions(),
                  params: dict | None = None, style=None) -> GameRecording:
    if Path(path).exists():
        raise GameError(f"{path} exists already; choose another name or delete it")
    recording = play(effects, options, params, style)
    write_game_bag(recording, path)
    return recording


def add_arguments(parser: argparse.ArgumentParser) -> None:
    """The game options of `generate_measured --game`."""
    parser.add_argument("--encoder-rate", type=float, default=250.0, help="/joint_states rate in a game, Hz (default 250)")
    parser.add_argument("--excitation", type=float, default=0.35,
                        help="game: share of 0.1 s in which a rod starts a random burst (default 0.35)")
    parser.add_argument("--style", default=None, metavar="STYLE",
                        help="game: play and record like others (foos_calibration.game_styles): 'random' draws each team's "
                             "style and the recording's conditions (encoder and camera rates, occlusions, lost samples, "
                             "command stamps) from --seed; a style's name (default, bang_bang, into_stops, spinning, "
                             "held_still, fast_commands, passive, aggressive) gives both teams that style and draws the "
                             "conditions. It overrides --fps and --encoder-rate; the bag gets it as generator_style.json")
    parser.add_argument("--camera-only", action="store_true",
                        help="game: write the camera's /ball/detection alone, no /joint_states and no commands (a real game "
                             "filmed from above); calibrate then infers the figure contacts from the ball and names no drive "
                             "effect")


def options_from(args: argparse.Namespace) -> GameOptions:
    options = GameOptions(duration=args.duration, seed=args.seed, fps=args.fps, noise=args.noise, dropout=args.dropout,
                          encoder_rate=args.encoder_rate, excitation=args.excitation, camera_only=args.camera_only)
    if not (options.duration > 0 and options.fps > 0 and options.noise >= 0 and 0 <= options.dropout < 1
            and options.encoder_rate > 0 and 0 <= options.excitation <= 1):
        raise GameError("need duration > 0, fps > 0, noise >= 0, 0 <= dropout < 1, encoder rate > 0, 0 <= excitation <= 1")
    return options


def describe(recording: GameRecording, path) -> str:
    written = ("the camera alone (no joint states, no commands)" if recording.camera_only else
               f"{len(recording.joint_t)} joint states, {len(recording.command_t)} commands per team")
    return (f"wrote {path}: a {recording.joint_t[-1]:.0f} s game, {len(recording.ball_t)} detections, "
            f"{written}, {recording.serves} serves, "
            f"{len(recording.goals)} goals, figure touches home {recording.touches[0]} away {recording.touches[1]}; "
            "hidden effects are not in the bag")


