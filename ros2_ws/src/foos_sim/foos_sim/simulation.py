"""The ROS-free simulation API shared by sim_node, the RL env and record_sim.

    sim = TableSimulation()                       # nominal table, the physics its parameter file names
    sim.reset(ball_position=(0.0, -0.2), ball_velocity=(0.3, 2.0))
    sim.set_command("home", [0, 0, 0, 0, 0, 20.0, 0, 0])
    goal = sim.advance(0.02)                      # 20 ms of physics, impacts included; "home", "away" or None
    x, y, z = sim.ball_position()

Commands follow the contract: per team 8 target joint velocities in the table frame
[goalie_slide, goalie_rotate, defence_slide, ..., attack_rotate], clipped to the drives' limits. A command acts
when it arrives: now, or at `set_command(..., at=t)`, a later simulation time. One that arrives within a physics
step splits that step there (a real drive acts on a command within its own servo cycle, not at the next 2 ms
step): the drives' generators switch command at that instant, as the servos do.

    sim.set_command("home", command, at=sim.time + 0.0013)   # sent now, arrives 1.3 ms later

Two physics (foos_sim.model_builder.PHYSICS, `solver.physics` in the parameter file, or the `physics`
argument): `fast` (the default, 500 Hz, impacts resolved by foos_sim.impacts between MuJoCo's collision
and its forces) and `reference` (the 20 kHz springs, stepped by mj_step alone).

The drives (`rods.drive` in the parameter file): `jerk_limited` (a robot table's: params/robot_table.yaml) follow each
command on an S-curve within a speed, an acceleration and a jerk limit (foos_sim.drive_profiles), the servo
targets set before every fast step (the setpoint at its middle, the rod started there: foos_sim.drives.
FollowingDrives) and every reference chunk (0.25 ms, the setpoint the servo's time constant ahead); the drive
effects act inside the generator. `servo` (params/servo_table.yaml, the former drives) are velocity servos on
the command itself, the default; there the drive effects (rod_latency, rod_speed_limit, rod_acceleration_limit) sit between
set_command and the servos (foos_sim.drive_limits.DriveShaper): the fast physics updates the servo targets
before every 2 ms step; the reference updates them at its chunk boundaries, only when a delayed command falls
due (within a chunk of its time) and every RAMP_UPDATE while a target ramps. Without drive effects nothing of
this runs on the servos.

Where a figure can strike the ball within a fast step and moves more than foos_sim.sweeps.FIGURE_STEP in it (a
kick on the jerk-limited drives), that part of the step is taken in sub-steps (foos_sim.sweeps, _sub_steps); the
impacts' look-ahead follows the figures that can strike the ball.
"""
from __future__ import annotations

import bisect
import itertools
import math
from pathlib import Path
from typing import Optional, Sequence

import mujoco
import numpy as np

from foos_core.names import (
    AXES,
    BALL_BODY,
    BALL_JOINT,
    COMMAND_SIZE,
    JOINT_NAMES,
    RODS,
    TEAMS,
    figure_team,
    team_joint_names,
)
from foos_core.table_params import load_params

from .drive_limits import DriveShaper, Servo, drive_limits_from_effects
from .drive_profiles import ProfileDrives, profile_limits
from .drives import FollowingDrives, ImplicitForceLimits
from .effects import DentSlopes
from .impacts import ImpactSolver
from .model_builder import build_model
from .sweeps import NO_WINDOW, RodIndex, SweepTest, free_box

HOME_SCORES = "home"  # ball centre crosses y = +half_length inside the away goal mouth
AWAY_SCORES = "away"

# The reference physics is stepped in MuJoCo in chunks of this many steps (0.25 ms at 20 kHz, shorter than
# a ball-figure contact, which lasts about 0.5 ms); goals and figure touches are checked after each.
REFERENCE_CHUNK_STEPS = 5
# A figure's surface may move a little faster than its drives' limits (servo overshoot, a rod's recoil).
FIGURE_SPEED_MARGIN = 1.2
# On the reference physics a ramping drive target (an acceleration limit) is updated this often: a ramp held
# 1 ms moves the target at most a_max * 1 ms (0.05 m/s at 50 m/s^2), well inside the servo's own lag.
RAMP_UPDATE = 0.001
# s: a command arriving this close to a step's boundary acts at the boundary (a step split shorter than this would
# move a 300 rad/s reversal by less than 0.03 mrad); a time this much before now is now.
ARRIVAL_SNAP = 1e-7


class CommandError(ValueError):
    """A rod command that a drive must refuse (wrong length, NaN or infinite values, unknown team)."""


class TableSimulation:
    """One table: a MuJoCo model and data with the contract's joints, commands and goal rules."""

    def __init__(self, params_file: str | Path | None = None, params: dict | None = None, physics: str | None = None):
        self.params = params if params is not None else load_params(params_file)
        self.model, builder = build_model(self.params, physics)
        self.physics = builder.physics_name
        self.data = mujoco.MjData(self.model)
        # Views of the state and the drives' targets (each read of data.qpos builds a new array object; MjData keeps
        # its buffers for life): the fast physics reads them several times a step.
        self._qpos, self._qvel, self._ctrl = self.data.qpos, self.data.qvel, self.data.ctrl
        self._impacts = (
            ImpactSolver(self.model, builder.impact_surfaces, FIGURE_SPEED_MARGIN * builder.figure_speed_limit(),
                         builder.reference_contact_duration(),
                         (self.params["field"]["width"] / 2, self.params["field"]["length"] / 2),
                         float(self.params["field"]["cover_height"]))
            if builder.fast else None
        )
        self._drives = None
        if builder.fast:
            self._drives = (FollowingDrives if profile_limits(self.params) is not None else ImplicitForceLimits)(self.model, self.data)
        self._dent_slopes = (
            DentSlopes(builder.physics.dents, float(self.params["ball"]["mass"]), float(self.params["gravity"]),
                       float(self.params["ball"]["radius"]))
            if builder.fast and builder.physics.dents else None
        )
        self._figure_reach = builder.figure_reach()
        field = self.params["field"]
        self.half_length = field["length"] / 2
        self.half_width = field["width"] / 2
        self.goal_half_width = field["goal_width"] / 2
        self.ball_radius = float(self.params["ball"]["radius"])
        self.timestep = float(self.model.opt.timestep)

        self._ball_body = self.model.body(BALL_BODY).id
        ball_joint = self.model.joint(BALL_JOINT)
        self._ball_qpos = slice(ball_joint.qposadr[0], ball_joint.qposadr[0] + 7)
        self._ball_qvel = slice(ball_joint.dofadr[0], ball_joint.dofadr[0] + 6)
        joints = [self.model.joint(name) for name in JOINT_NAMES]
        self._joint_qpos = np.array([j.qposadr[0] for j in joints])
        self._joint_qvel = np.array([j.dofadr[0] for j in joints])
        self._joint_range = np.array([j.range if j.limited[0] else (-np.inf, np.inf) for j in joints])
        # ctrl indices of each team's 8 drives, in command order
        self._team_ctrl = {
            team: np.array([self.model.actuator(name).id for name in team_joint_names(team)]) for team in TEAMS
        }
        self.command_limits = np.array([self.model.actuator(n).ctrlrange[1] for n in team_joint_names("home")])
        self._all_ctrl = np.concatenate([self._team_ctrl[t] for t in TEAMS])
        drive_limits = drive_limits_from_effects(self.params.get("effects"))
        nominal_profiles = profile_limits(self.params)
        # Jerk-limited drives (params/robot_table.yaml) plan every command through their generators, effects or not; the
        # plain servos (params/servo_table.yaml) only shape commands when the file has drive effects.
        self._profiles = None
        if nominal_profiles is not None:
            # On the reference the servos integrate at 20 kHz and lag their targets by inertia / gain (0.07-0.2 ms:
            # 0.03 rad behind at 250 rad/s); fed the setpoint that much ahead they follow it. The fast physics
            # starts each step at its target instead (foos_sim.drives, follow).
            lead = None if builder.fast else self._servo_time_constants()
            self._profiles = ProfileDrives(nominal_profiles, drive_limits, lead)
        self._drive_effects = drive_limits
        self._shaper = (DriveShaper(drive_limits, np.tile(self.command_limits, len(TEAMS)))
                        if drive_limits and self._profiles is None else None)
        # Each rod's y and the dofs and actuators of its slide and rotation: the fast physics sub-steps where a
        # figure can strike the ball (foos_sim.sweeps).
        rods = []
        for team in TEAMS:
            for rod in RODS:
                slide, rotate = (self.model.joint(f"{team}_{rod}_{axis}") for axis in AXES)
                layout = self.params["rods"]["layout"][f"{team}_{rod}"]
                rods.append(RodIndex(y=float(layout["y"]), slide_dof=int(slide.dofadr[0]), rotate_dof=int(rotate.dofadr[0]),
                                     slide_ctrl=int(self.model.actuator(f"{team}_{rod}_slide").id),
                                     rotate_ctrl=int(self.model.actuator(f"{team}_{rod}_rotate").id),
                                     slide_qpos=int(slide.qposadr[0]), rotate_qpos=int(rotate.qposadr[0]),
                                     figures=int(layout["figures"]), spacing=float(layout["spacing"])))
        self._sweeps = SweepTest(self.params, rods, self._figure_reach or 0.0, self._ball_qpos.start, self._ball_qvel.start,
                                 free_box(self.model, self.ball_radius))
        # For each team (TEAMS order), which geoms are its figures', indexed by geom id.
        geom_teams = [figure_team(self.model.geom(g).name) for g in range(self.model.ngeom)]
        self._team_figure_geoms = tuple(np.array([owner == team for owner in geom_teams]) for team in TEAMS)
        self.reset()

    # --- state ---------------------------------------------------------------------------------
    @property
    def time(self) -> float:
        return float(self.data.time)

    def ball_position(self) -> np.ndarray:
        return self.data.qpos[self._ball_qpos][:3].copy()

    def ball_velocity(self) -> np.ndarray:
        """Linear velocity of the ball centre, table frame."""
        return self.data.qvel[self._ball_qvel][:3].copy()

    def ball_angular_velocity(self) -> np.ndarray:
        """Angular velocity, table frame (MuJoCo keeps a free joint's in the body frame)."""
        local = self.data.qvel[self._ball_qvel][3:]
        world = np.zeros(3)
        mujoco.mju_rotVecQuat(world, local, self.data.qpos[self._ball_qpos][3:])
        return world

    def joint_positions(self) -> np.ndarray:
        """The 16 rod joints in JOINT_NAMES order (m for slides, rad for rotations)."""
        return self.data.qpos[self._joint_qpos].copy()

    def joint_velocities(self) -> np.ndarray:
        return self.data.qvel[self._joint_qvel].copy()

    def joint_efforts(self) -> np.ndarray:
        forces = self._drives.efforts(self.data) if self._drives is not None else self.data.actuator_force
        return forces[np.concatenate([self._team_ctrl[t] for t in TEAMS])].copy()

    def figure_contacts(self) -> tuple[bool, bool]:
        """Whether the ball touched a home figure and an away figure (TEAMS order) during the last
        advance() or step(): an impact, or a contact such as a push. (False, False) after a reset."""
        return self._touched_in_call[0], self._touched_in_call[1]

    def figure_touches(self) -> tuple[int, int]:
        """How many touches each team's figures (TEAMS order) have made since reset(): a touch begins when
        the ball starts touching one of the team's figures (checked every step at the fast rate, every
        0.25 ms on the reference)."""
        return self._touch_count[0], self._touch_count[1]

    def last_touch_ball_position(self, team: str) -> Optional[np.ndarray]:
        """Where the ball was when `team`'s figures last began touching it since reset(), or None."""
        position = self._touch_position[TEAMS.index(team)]
        return None if position is None else position.copy()

    def last_touch_joint_velocities(self, team: str) -> Optional[np.ndarray]:
        """The 16 joint velocities as `team`'s figures last began touching the ball since reset(), or None: at the
        start of the fast step or sub-step in which the touch began (the rods' velocities through it), or of the
        reference's chunk (0.25 ms). A step's velocities read before it lag on the jerk-limited drives: the fast
        physics reports its drive's setpoint at the middle of the last (sub-)step."""
        velocities = self._touch_velocities[TEAMS.index(team)]
        return None if velocities is None else velocities.copy()

    def state_is_finite(self) -> bool:
        """False once the physics has diverged (a NaN or infinite position anywhere in the model)."""
        return bool(np.all(np.isfinite(self.data.qpos)))

    # --- control -------------------------------------------------------------------------------
    def validate_command(self, command: Sequence[float]) -> np.ndarray:
        """The command as 8 finite floats, or CommandError saying what is wrong with it."""
        values = np.asarray(command, dtype=float).ravel()
        if values.size != COMMAND_SIZE:
            raise CommandError(f"a rod command has {COMMAND_SIZE} values, got {values.size}")
        if np.count_nonzero(np.isfinite(values)) != values.size:  # (count_nonzero: a fraction of ndarray.all()'s cost)
            raise CommandError("a rod command must not contain NaN or infinite values")
        return values

    def set_command(self, team: str, command: Sequence[float], at: float | None = None) -> np.ndarray:
        """Set one team's 8 target joint velocities; returns them clipped to the drive limits.

        `at`: the simulation time the command arrives at the drives (default now). A later one waits and acts at
        that instant, within a physics step if it falls inside one (the step is split there); a team's commands act
        in the order they arrive."""
        if team not in self._team_ctrl:
            raise CommandError(f"unknown team `{team}` (expected one of {TEAMS})")
        clipped = np.minimum(np.maximum(self.validate_command(command), -self.command_limits), self.command_limits)
        if at is not None:
            at = float(at)
            if not math.isfinite(at) or at < self.time - ARRIVAL_SNAP:
                raise CommandError(f"a command arrives at a finite time no earlier than now ({self.time:.6f} s), got {at}")
            if at > self.time + ARRIVAL_SNAP:
                bisect.insort(self._arrivals, (at, next(self._arrival_order), TEAMS.index(team), clipped))
                return clipped
        self._apply(TEAMS.index(team), clipped)
        return clipped

    def _apply(self, team: int, clipped: np.ndarray) -> None:
        """A team's command acts from now."""
        if self._profiles is not None:
            self._profiles.receive(self.time, team, clipped)  # acts through the drive's generator
            return
        if self._shaper is not None:
            self._shaper.receive(self.time, team, clipped)  # acts through the drive's limits
            return
        self.data.ctrl[self._team_ctrl[TEAMS[team]]] = clipped
        if self._drives is not None:
            self._drives.disturb()

    def _deliver(self) -> None:
        """Apply the commands that have arrived by now."""
        arrivals, now = self._arrivals, self.time + ARRIVAL_SNAP
        while arrivals and arrivals[0][0] <= now:
            _, _, team, clipped = arrivals.pop(0)
            self._apply(team, clipped)

    def stop_team(self, team: str) -> None:
        # A stop is a zero command to the drives: through the generators, or after the servos' dead time.
        self._apply(TEAMS.index(team), np.zeros(COMMAND_SIZE))

    def drive_limits(self):
        """The drive effects applied (foos_sim.drive_limits.DriveLimits), or None on nominal drives."""
        return self._drive_effects

    def drive_profiles(self):
        """The jerk-limited drives' nominal limits (foos_sim.drive_profiles.ProfileLimits), or None on the
        plain velocity servos."""
        return profile_limits(self.params)

    def drive_servo(self) -> Servo:
        """The 16 velocity servos (JOINT_NAMES order): reflected inertia, gain and force limit."""
        full = np.zeros((self.model.nv, self.model.nv))
        mujoco.mj_fullM(self.model, self.data, full)
        actuators = self._all_ctrl
        return Servo(inertia=full[self._joint_qvel, self._joint_qvel].copy(),
                     gain=self.model.actuator_gainprm[actuators, 0].copy(),
                     force_limit=self.model.actuator_forcerange[actuators, 1].copy() if self._drives is None
                     else self._drives.limit[actuators].copy())

    def _servo_time_constants(self) -> np.ndarray:
        """s, each drive's servo time constant (inertia / gain), JOINT_NAMES order."""
        mujoco.mj_forward(self.model, self.data)  # the mass matrix, before the first step
        servo = self.drive_servo()
        return servo.inertia / servo.gain

    def place_ball(self, position: Sequence[float], velocity: Sequence[float] = (0.0, 0.0), rolling: bool = True) -> None:
        """Put the ball somewhere with a velocity (a hand launch), leaving the rods as they are."""
        position, velocity = _ball_vectors(position, velocity, self.ball_radius)
        qpos = self.data.qpos[self._ball_qpos]
        qpos[:3] = position
        qpos[3:] = (1.0, 0.0, 0.0, 0.0)
        qvel = self.data.qvel[self._ball_qvel]
        qvel[:3] = velocity
        # Identity orientation: the body frame is the table frame, so this spin is in table axes.
        qvel[3:] = (-velocity[1] / self.ball_radius, velocity[0] / self.ball_radius, 0.0) if rolling else 0.0
        self._goal = None
        if self._drives is not None:
            self._drives.disturb()
        mujoco.mj_forward(self.model, self.data)

    # --- stepping ------------------------------------------------------------------------------
    def advance(self, seconds: float) -> Optional[str]:
        """Run `seconds` of physics, impacts included; returns the team that has scored since the last
        reset() or place_ball(), or None.

        Time moves in whole physics steps; what a call asks beyond them is carried to the next call, so
        over many calls `time` follows the sum asked within half a step. A goal is latched: once the
        ball centre has crossed an end line inside the mouth, the goal stands until reset() or
        place_ball(), even if the ball bounces back out of the pocket.
        """
        seconds = float(seconds)
        if not (math.isfinite(seconds) and seconds >= 0.0):
            raise ValueError(f"advance() takes a finite number of seconds >= 0, got {seconds}")
        self._time_owed += seconds
        steps = math.floor(self._time_owed / self.timestep + 0.5)
        self._time_owed -= steps * self.timestep
        return self.step(steps)

    def step(self, n: int = 1) -> Optional[str]:
        """Advance n physics steps of this simulation's own rate (`timestep`), impacts included; returns
        what advance() returns. advance(seconds) is the same without knowing the rate."""
        self._touched_in_call = [False, False]
        n = int(n)
        if n <= 0:
            return self.goal()
        if self._impacts is not None:
            self._fast_steps(n)
        else:
            self._reference_steps(n)
        return self._goal

    def _reference_steps(self, n: int) -> None:
        h, remaining = self.timestep, n
        while remaining > 0:
            chunk = min(remaining, REFERENCE_CHUNK_STEPS)
            if self._arrivals:
                self._deliver()
                if self._arrivals and self._arrivals[0][0] < self.data.time + chunk * h - ARRIVAL_SNAP:
                    # Up to the step a command arrives in; that step is split at its arrival.
                    chunk = int((self._arrivals[0][0] - self.data.time + ARRIVAL_SNAP) / h)
                    if chunk == 0:
                        self._split_step(h, self._reference_chunk)
                        remaining -= 1
                        continue
            self._reference_chunk(h, chunk)
            remaining -= chunk

    def _reference_chunk(self, h: float, steps: int = 1) -> None:
        """`steps` MuJoCo steps of h (h shorter than the model's timestep: a part of a step split by a command)."""
        model, data, shaper, profiles = self.model, self.data, self._shaper, self._profiles
        if profiles is not None:
            targets = profiles.targets(data.time, steps * h)
            if targets is not None:
                data.ctrl[self._all_ctrl] = targets
        if shaper is not None and not shaper.idle and data.time >= shaper.next_update - 0.5 * self.timestep:
            # The target ramps over the time since its last update, at most one ramp interval (an idle
            # shaper's last update may be long ago).
            data.ctrl[self._all_ctrl] = shaper.target(data.time, min(data.time - shaper.updated_at, RAMP_UPDATE))
            shaper.schedule(data.time, RAMP_UPDATE)
        np.copyto(self._step_qvel, data.qvel)
        if h != self.timestep:
            model.opt.timestep = h
        try:
            mujoco.mj_step(model, data, nstep=steps)
        finally:
            model.opt.timestep = self.timestep
        ncon = data.ncon
        if ncon:
            # Every contact of the model is one of the ball's pairs: one with a figure geom is a touch.
            geoms = data.contact.geom[:ncon]
            self._note_touches([bool(figures[geoms].any()) for figures in self._team_figure_geoms])
        else:
            self._note_touches([False, False])
        if self._goal is None:
            self._goal = self._goal_now()

    def _fast_steps(self, n: int) -> None:
        self._impacts.update_gaps(self.data)  # the state may have been set since the last step (reset, place_ball)
        h = self.timestep
        for i in range(n):
            if self._arrivals:
                self._deliver()
            if self._arrivals and self._arrivals[0][0] < self.data.time + h - ARRIVAL_SNAP:
                self._split_step(h, self._fast_part)  # a command arrives within this step
            else:
                self._fast_part(h)
            # Every other step (4 ms; a shot into a goal spends 16 ms in the pocket before it could come out).
            if self._goal is None and (i & 1 or i == n - 1):
                self._goal = self._goal_now()

    def _split_step(self, h: float, part) -> None:
        """One step of h taken as parts that end where commands arrive within it (`part(length)` steps one), each
        command applied at its arrival: the drives switch there, not at the step's end. The step ends on the time
        it would have without the split."""
        data, arrivals = self.data, self._arrivals
        end = data.time + h
        while arrivals and arrivals[0][0] < end - ARRIVAL_SNAP:
            arrival = arrivals[0][0]
            part(arrival - data.time)
            data.time = arrival
            self._deliver()
        part(end - data.time)
        data.time = end

    def _fast_part(self, h: float) -> None:
        """One fast step of h: the model's timestep, or a part of a step split by a command's arrival."""
        data, impacts, drives, shaper, profiles = self.data, self._impacts, self._drives, self._shaper, self._profiles
        split = h != self.timestep
        if split:
            self.model.opt.timestep = h
            drives.set_timestep(h)
            figure_speed = impacts.figure_speed_limit
            if profiles is None:
                impacts.set_motion(data, figure_speed, h)
        try:
            if profiles is not None:
                # A part: its middle's setpoint alone (the 32-step block of targets() is for whole steps).
                targets = profiles.sub_targets(data.time, np.array([0.5 * h]))[0] if split else profiles.targets(data.time, h)
                if targets is not None:
                    self._ctrl[self._all_ctrl] = targets
                    drives.disturb()
                window = self._sweeps.window(self._qpos, self._qvel, self._ctrl, h)
                impacts.reachable = window.reachable
                runs = None if window is NO_WINDOW else window.sub_steps(h)  # NO_WINDOW (the usual step): one step
                if runs is None or (len(runs) == 1 and runs[0][1] == 1):
                    impacts.set_motion(data, FIGURE_SPEED_MARGIN * window.figure_speed, h)
                    self._fast_step()
                else:
                    self._sub_steps(runs, h)
            else:
                if shaper is not None and not shaper.idle:
                    data.ctrl[self._all_ctrl] = shaper.target(data.time, h)
                    drives.disturb()
                self._fast_step()
        finally:
            if split:
                self.model.opt.timestep = self.timestep
                drives.set_timestep(self.timestep)
                if profiles is None:
                    impacts.set_motion(data, figure_speed, self.timestep)

    def _sub_steps(self, runs: list[tuple[float, int, float]], h: float) -> None:
        """A fast step of h as runs of (length, count, figure speed) sub-steps (foos_sim.sweeps.Window.sub_steps),
        the drives' targets taken at the middle of each. After a sub-step with an impact the ball has left the
        straight path the runs were planned on: the rest of the step is planned again from there."""
        model, data, impacts, drives, profiles = self.model, self.data, self._impacts, self._drives, self._profiles
        end = data.time + h
        try:
            while runs:
                middles, offset = [], 0.0
                for length, count, _ in runs:
                    middles.extend(offset + (k + 0.5) * length for k in range(count))
                    offset += count * length
                targets = profiles.sub_targets(data.time, np.array(middles))
                k, struck = 0, False
                for length, count, figure_speed in runs:
                    model.opt.timestep = length
                    drives.set_timestep(length)
                    impacts.set_motion(data, FIGURE_SPEED_MARGIN * figure_speed, length)
                    for _ in range(count):
                        self._ctrl[self._all_ctrl] = targets[k]
                        k += 1
                        drives.disturb()
                        struck = self._fast_step()
                        if struck:
                            break
                    if struck:
                        break
                rest = end - data.time
                runs = []
                if struck and rest > 1e-3 * h:
                    self._ctrl[self._all_ctrl] = profiles.sub_targets(data.time, np.array([0.5 * rest]))[0]
                    window = self._sweeps.window(self._qpos, self._qvel, self._ctrl, rest)
                    runs = window.sub_steps(rest)
                    impacts.reachable = window.reachable
        finally:
            model.opt.timestep = self.timestep
            drives.set_timestep(self.timestep)

    def _fast_step(self) -> bool:
        """One step of the fast physics at the model's timestep, impacts included; True if an impact changed the
        ball's or a rod's motion in it."""
        model, data, impacts, drives, dents = self.model, self.data, self._impacts, self._drives, self._dent_slopes
        drives.update()
        np.copyto(self._step_qvel, self._qvel)  # the velocities through this step (last_touch_joint_velocities)
        if dents is not None:
            data.xfrc_applied[self._ball_body, :2] = dents.force(*data.qpos[self._ball_qpos][:3].tolist())
        mujoco.mj_step1(model, data)
        struck = impacts.resolve(data)
        if struck:
            drives.after_impact()  # a rod may have been jolted
            mujoco.mj_step1(model, data)  # positions and velocities changed: collide and evaluate again
        mujoco.mj_step2(model, data)
        impacts.after_step(data)
        touching = impacts.touching
        if touching[0] or touching[1] or self._touching[0] or self._touching[1]:
            self._note_touches(touching)
            drives.disturb()  # a figure held by the ball: its drive may be past its limit
        return struck

    def _note_touches(self, touching: Sequence[bool]) -> None:
        for team in (0, 1):
            if touching[team]:
                if not self._touching[team]:
                    self._touch_count[team] += 1
                    self._touch_position[team] = self.data.qpos[self._ball_qpos][:3].copy()
                    self._touch_velocities[team] = self._step_qvel[self._joint_qvel]
                self._touched_in_call[team] = True
            self._touching[team] = touching[team]

    def goal(self) -> Optional[str]:
        """The team that has scored since the last reset ("home" attacks +y), or None."""
        if self._goal is None:
            self._goal = self._goal_now()
        return self._goal

    def _goal_now(self) -> Optional[str]:
        adr = self._ball_qpos.start
        x, y = self._qpos[adr:adr + 2].tolist()
        if abs(x) > self.goal_half_width:
            return None
        if y > self.half_length:
            return HOME_SCORES
        if y < -self.half_length:
            return AWAY_SCORES
        return None

    def ball_penetration(self) -> float:
        """Deepest overlap (m, >= 0) of the ball with anything it touches, field included."""
        contacts = self.data.contact
        if self.data.ncon == 0:
            return 0.0
        return max(0.0, -float(np.min(contacts.dist[: self.data.ncon])))

    def ball_is_clear(self, tolerance: float = 1e-4) -> bool:
        """True when the ball overlaps nothing (as placed by place_ball/reset): no figure, no wall."""
        return self.ball_penetration() <= tolerance

    def ball_on_field(self) -> bool:
        x, y = self.data.qpos[self._ball_qpos][:2]
        return abs(x) <= self.half_width and abs(y) <= self.half_length

    # --- reset ---------------------------------------------------------------------------------
    def reset(
        self,
        ball_position: Sequence[float] = (0.0, 0.0),
        ball_velocity: Sequence[float] = (0.0, 0.0),
        rolling: bool = True,
        joint_positions: Optional[Sequence[float]] = None,
    ) -> None:
        """Rods centred and hanging (or at joint_positions), drives stopped, ball on the surface.

        ball_position is (x, y) or (x, y, z); ball_velocity (vx, vy) or (vx, vy, vz). A rolling ball
        gets the spin of rolling without slip; otherwise it starts sliding with no spin.
        """
        _ball_vectors(ball_position, ball_velocity, self.ball_radius)  # refuse bad input before resetting
        mujoco.mj_resetData(self.model, self.data)
        if self._shaper is not None:
            self._shaper.reset()
        if self._profiles is not None:
            self._profiles.reset()
        self._time_owed = 0.0
        self._arrivals: list = []  # commands still to arrive: (time, order, team, command), by time
        self._arrival_order = itertools.count()
        self._touching = [False, False]  # touching each team's figures at the last check
        self._touched_in_call = [False, False]
        self._touch_count = [0, 0]
        self._touch_position: list[Optional[np.ndarray]] = [None, None]
        self._touch_velocities: list[Optional[np.ndarray]] = [None, None]
        self._step_qvel = self.data.qvel.copy()
        if joint_positions is not None:
            values = np.asarray(joint_positions, dtype=float)
            if values.shape != (len(JOINT_NAMES),) or not np.all(np.isfinite(values)):
                raise ValueError(f"joint_positions holds {len(JOINT_NAMES)} finite values")
            self.data.qpos[self._joint_qpos] = np.clip(values, self._joint_range[:, 0], self._joint_range[:, 1])
        self.place_ball(ball_position, ball_velocity, rolling)


def _ball_vectors(position: Sequence[float], velocity: Sequence[float], radius: float) -> tuple[np.ndarray, np.ndarray]:
    """(x, y[, z]) and (vx, vy[, vz]) as 3-vectors; z defaults to resting on the surface."""
    p = np.asarray(position, dtype=float).ravel()
    v = np.asarray(velocity, dtype=float).ravel()
    if p.size not in (2, 3) or v.size not in (2, 3):
        raise ValueError("ball position and velocity have 2 or 3 components")
    if not (np.all(np.isfinite(p)) and np.all(np.isfinite(v))):
        raise ValueError("ball state must be finite")
    full_p = np.array([0.0, 0.0, radius])
    full_p[: p.size] = p
    full_v = np.zeros(3)
    full_v[: v.size] = v
    return full_p, full_v
