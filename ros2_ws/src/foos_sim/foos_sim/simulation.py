"""The ROS-free simulation API shared by sim_node, the RL env and calibration.

    sim = TableSimulation()                       # nominal table
    sim.reset(ball_position=(0.0, -0.2), ball_velocity=(0.3, 2.0))
    sim.set_command("home", [0, 0, 0, 0, 0, 20.0, 0, 0])
    goal = sim.step(100)                          # 100 physics steps; "home", "away" or None
    x, y, z = sim.ball_position()

Commands follow the contract: per team 8 target joint velocities in the table frame
[goalie_slide, goalie_rotate, defence_slide, ..., attack_rotate], clipped to the drives' limits.
"""
from __future__ import annotations

from pathlib import Path
from typing import Optional, Sequence

import mujoco
import numpy as np

from foos_core.names import BALL_JOINT, COMMAND_SIZE, JOINT_NAMES, TEAMS, figure_team, team_joint_names
from foos_core.table_params import load_params

from .model_builder import model_from_params

HOME_SCORES = "home"  # ball centre crosses y = +half_length inside the away goal mouth
AWAY_SCORES = "away"

# Goals are checked at least this often (5 ms at 20 kHz): a 10 m/s shot spends about 16 ms in a pocket
# before it could bounce back out, so no goal is missed between checks.
GOAL_CHECK_STEPS = 100


class CommandError(ValueError):
    """A rod command that a drive must refuse (wrong length, NaN or infinite values, unknown team)."""


class TableSimulation:
    """One table: a MuJoCo model and data with the contract's joints, commands and goal rules."""

    def __init__(self, params_file: str | Path | None = None, params: dict | None = None):
        self.params = params if params is not None else load_params(params_file)
        self.model = model_from_params(self.params)
        self.data = mujoco.MjData(self.model)
        field = self.params["field"]
        self.half_length = field["length"] / 2
        self.half_width = field["width"] / 2
        self.goal_half_width = field["goal_width"] / 2
        self.ball_radius = float(self.params["ball"]["radius"])
        self.timestep = float(self.model.opt.timestep)

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
        return self.data.actuator_force[np.concatenate([self._team_ctrl[t] for t in TEAMS])].copy()

    def figure_contacts(self) -> tuple[bool, bool]:
        """Whether the ball touches a home figure and an away figure now (TEAMS order), from the
        contacts of the last step. Every contact of the model is one of the ball's pairs, so a contact
        with a figure geom is the ball touching that figure."""
        ncon = self.data.ncon
        if ncon == 0:
            return False, False
        geoms = self.data.contact.geom[:ncon]
        home, away = (bool(figures[geoms].any()) for figures in self._team_figure_geoms)
        return home, away

    def state_is_finite(self) -> bool:
        """False once the physics has diverged (a NaN or infinite position anywhere in the model)."""
        return bool(np.all(np.isfinite(self.data.qpos)))

    # --- control -------------------------------------------------------------------------------
    def validate_command(self, command: Sequence[float]) -> np.ndarray:
        """The command as 8 finite floats, or CommandError saying what is wrong with it."""
        values = np.asarray(command, dtype=float).ravel()
        if values.size != COMMAND_SIZE:
            raise CommandError(f"a rod command has {COMMAND_SIZE} values, got {values.size}")
        if not np.all(np.isfinite(values)):
            raise CommandError("a rod command must not contain NaN or infinite values")
        return values

    def set_command(self, team: str, command: Sequence[float]) -> np.ndarray:
        """Set one team's 8 target joint velocities; returns them clipped to the drive limits."""
        if team not in self._team_ctrl:
            raise CommandError(f"unknown team `{team}` (expected one of {TEAMS})")
        clipped = np.clip(self.validate_command(command), -self.command_limits, self.command_limits)
        self.data.ctrl[self._team_ctrl[team]] = clipped
        return clipped

    def stop_team(self, team: str) -> None:
        self.data.ctrl[self._team_ctrl[team]] = 0.0

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
        mujoco.mj_forward(self.model, self.data)

    # --- stepping ------------------------------------------------------------------------------
    def step(self, n: int = 1) -> Optional[str]:
        """Advance n physics steps; returns the team that has scored since the last reset, or None.

        A goal is latched: once the ball centre has crossed an end line inside the mouth, the goal
        stands until reset(), even if the ball bounces back out of the pocket.
        """
        remaining = int(n)
        while remaining > 0:
            chunk = min(remaining, GOAL_CHECK_STEPS)
            mujoco.mj_step(self.model, self.data, nstep=chunk)
            remaining -= chunk
            if self._goal is None:
                self._goal = self._goal_now()
        return self._goal

    def goal(self) -> Optional[str]:
        """The team that has scored since the last reset ("home" attacks +y), or None."""
        if self._goal is None:
            self._goal = self._goal_now()
        return self._goal

    def _goal_now(self) -> Optional[str]:
        x, y = self.data.qpos[self._ball_qpos][:2]
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
