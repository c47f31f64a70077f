"""A game bag's drive data: /joint_states and the two command topics, read and checked for the rod fit.

    encoders, drives = read_game(bag)    # each None when the bag lacks it
    model = drive_model(params)          # the nominal drives of a parameter tree

Bad data is a RodDataError with a one-line reason: commands without joint states (the drives cannot be
identified without their encoders), joint states whose names are not the contract's 16 joints, stamps
that go backwards, joint states and commands that do not overlap in time.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import numpy as np

from foos_bag import BagError, messages, read_commands, topics
from foos_core.joints import joint_order, take_joints
from foos_core.names import JOINT_NAMES, JOINT_STATES_TOPIC, TEAMS, command_topic
from foos_core.stamps import stamp_to_seconds
from foos_sim.simulation import TableSimulation

from .rods import DriveData, DriveModel, RodDataError

MIN_DURATION = 10.0  # s of joint states and commands together, for two folds of several stretches each
FIT_TIMESTEP = 0.002  # s: the servo's implicit update in the predictor (the fast physics' step)


@dataclass
class Encoders:
    """The rods' encoders: stamps (N,) and the 16 joints' positions and velocities (N, 16), JOINT_NAMES columns."""

    t: np.ndarray
    position: np.ndarray
    velocity: np.ndarray


def read_game(bag: str | Path) -> tuple[Optional[Encoders], Optional[DriveData]]:
    """The bag's encoders (None without /joint_states) and, with both teams' commands, the drive data (else None)."""
    bag = Path(bag)
    present = set(topics(bag))
    command_topics = [command_topic(team) for team in TEAMS]
    has_commands = [topic in present for topic in command_topics]
    if JOINT_STATES_TOPIC not in present:
        if any(has_commands):
            raise RodDataError(f"{bag}: the bag has rod commands but no {JOINT_STATES_TOPIC}; the drives cannot be "
                               "identified without their encoders (record /joint_states too)")
        return None, None
    encoders = read_encoders(bag)
    if not any(has_commands):
        return encoders, None  # encoders without commands (rods moved by hand): the figures' poses only
    return encoders, _drive_data(bag, encoders, command_topics, has_commands)


def read_encoders(bag: Path) -> Encoders:
    """/joint_states, checked: the contract's 16 names throughout, stamps increasing, finite positions."""
    t, rows, names = [], [], None
    for _, _, msg in messages(bag, [JOINT_STATES_TOPIC]):
        if names is None:
            names = list(msg.name)
            unknown = sorted(set(names) - set(JOINT_NAMES))
            missing = sorted(set(JOINT_NAMES) - set(names))
            if unknown or missing:
                raise RodDataError(f"{bag}: {JOINT_STATES_TOPIC} names {len(names)} joints that are not the contract's 16 "
                                   f"(unknown: {', '.join(unknown[:3]) or 'none'}; missing: {', '.join(missing[:3]) or 'none'})")
            order = joint_order(names, wanted=list(JOINT_NAMES))
        elif list(msg.name) != names:
            raise RodDataError(f"{bag}: {JOINT_STATES_TOPIC} changes its joint names mid-recording")
        n = len(names)
        position = np.asarray(msg.position, dtype=float)
        velocity = np.asarray(msg.velocity, dtype=float) if len(msg.velocity) == n else np.full(n, np.nan)
        if position.shape != (n,):
            raise RodDataError(f"{bag}: a {JOINT_STATES_TOPIC} message has {position.size} positions for {n} names")
        rows.append(take_joints(np.stack([position, velocity]), order))
        t.append(stamp_to_seconds(msg.header.stamp))
    t = np.asarray(t)
    if len(t) < 2:
        raise RodDataError(f"{bag}: {JOINT_STATES_TOPIC} has {len(t)} message(s); a game needs its encoders throughout")
    back = np.flatnonzero(np.diff(t) <= 0)
    if back.size:
        raise RodDataError(f"{bag}: {JOINT_STATES_TOPIC} stamps go backwards (or repeat) at {t[back[0]]:.3f} s -> "
                           f"{t[back[0] + 1]:.3f} s; encoder stamps must increase (a broken time base)")
    values = np.asarray(rows)
    position, velocity = values[:, 0], values[:, 1]
    if not np.isfinite(position).all():
        raise RodDataError(f"{bag}: {JOINT_STATES_TOPIC} holds NaN or infinite positions")
    if not np.isfinite(velocity).all():
        velocity = np.gradient(position, t, axis=0)  # encoders that publish no velocity: differentiate
    return Encoders(t, position, velocity)


def _drive_data(bag: Path, encoders: Encoders, command_topics: list[str], has_commands: list[bool]) -> DriveData:
    t, position, velocity = encoders.t, encoders.position, encoders.velocity
    if not all(has_commands):
        lacking = [topic for topic, has in zip(command_topics, has_commands) if not has]
        raise RodDataError(f"{bag}: joint states but no {', '.join(lacking)}; the drives are identified against the commands "
                           "both teams sent")
    command_t, commands = {}, {}
    for team in TEAMS:
        try:
            read = read_commands(bag, team)
        except BagError as error:
            raise RodDataError(str(error).splitlines()[0]) from None
        if np.any(np.diff(read.t) < 0):
            raise RodDataError(f"{bag}: {command_topic(team)} arrival times go backwards")
        if not np.isfinite(read.values).all():
            raise RodDataError(f"{bag}: {command_topic(team)} holds NaN or infinite values")
        command_t[team], commands[team] = read.t, read.values
    start = max(t[0], *(c[0] for c in command_t.values()))
    end = min(t[-1], *(c[-1] for c in command_t.values()))
    if end - start < MIN_DURATION:
        raise RodDataError(f"{bag}: joint states and commands overlap for {max(0.0, end - start):.1f} s (need {MIN_DURATION:g} s); "
                           "are they on the same clock?")
    keep = (t >= start) & (t <= end + 0.5)
    return DriveData(t[keep], position[keep], velocity[keep], command_t, commands)


def drive_model(params: dict) -> DriveModel:
    """The nominal drives of a parameter tree: servo inertia, gain and force limit, command limits, stops."""
    nominal = {**params, "effects": [], "solver": {**params.get("solver", {}), "physics": "fast"}}
    sim = TableSimulation(params=nominal, physics="fast")
    layout = params["rods"]["layout"]
    travel = np.array([float(layout[name.rsplit("_", 1)[0]]["travel"]) if name.endswith("_slide") else np.inf
                       for name in JOINT_NAMES])
    # The velocity servos as the table's physics runs them: the fast physics' 2 ms implicit steps, or the servo law
    # itself (the 20 kHz reference resolves the servos' 0.1-5 ms time constants, as a real drive has them).
    continuous = str(params.get("solver", {}).get("physics", "fast")) != "fast"
    return DriveModel(sim.drive_servo(), np.tile(sim.command_limits, len(TEAMS)), travel, FIT_TIMESTEP, sim.drive_profiles(),
                      continuous)
