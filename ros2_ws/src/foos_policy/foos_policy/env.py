"""FoosballEnv: the paper's task on the foos_sim table as a gymnasium env (ROS-free).

    env = FoosballEnv(reset="hardened", opponent="scripted")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Control runs at `control_rate` Hz (50 by default) over the 20 kHz physics. Inside one control step
the simulation advances in chunks of CHUNK steps (0.25 ms, shorter than a ball-figure contact, which
lasts about 0.5 ms): the episode ends at the first chunk after which the simulation reports a goal,
and every rod-ball touch is counted.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Optional

import gymnasium as gym
import numpy as np

from foos_core.names import COMMAND_SIZE, TEAMS
from foos_sim.simulation import TableSimulation

from .observation import ACTION_LIMIT, OBS_SIZE, action_to_command, observe
from .tasks import PaperReward, make_opponent, make_reset

CHUNK = 5  # physics steps between goal / touch checks


@dataclass
class EnvConfig:
    reset: str = "paper"                # paper | hardened
    opponent: str = "none"              # none | scripted | selfplay | lifted
    opponent_policy: Optional[str] = None
    control_rate: float = 50.0          # Hz
    max_steps: int = 500                # time limit: 10 s at 50 Hz
    stagnant_speed: float = 0.05        # m/s, planar ball speed under which the ball counts as stagnant
    stagnant_steps: int = 50            # control steps (1 s at 50 Hz) of stagnation that end an episode
    params_file: Optional[str] = None
    reward: PaperReward = field(default_factory=PaperReward)


@dataclass
class EpisodeStats:
    """Contact-conditioned bookkeeping of one episode (home team's view)."""

    length: int = 0
    ret: float = 0.0
    goal: Optional[str] = None          # team that scored, or None
    stagnant: bool = False
    touches_home: int = 0
    touches_away: int = 0
    last_home_touch_y: Optional[float] = None
    final_y: float = 0.0

    def summary(self) -> dict[str, Any]:
        touched = self.touches_home > 0
        progress = (self.final_y - self.last_home_touch_y) if self.last_home_touch_y is not None else 0.0
        return {
            "length": self.length,
            "return": self.ret,
            "win": float(self.goal == "home"),
            "lose": float(self.goal == "away"),
            "term_goal": float(self.goal is not None),
            "stagnant": float(self.stagnant),
            "touches": self.touches_home,
            "touches_away": self.touches_away,
            "home_touched": float(touched),
            "goal_after_touch": float(self.goal == "home" and touched),
            "goal_without_touch": float(self.goal == "home" and not touched),
            "progress_after_touch": float(progress),
        }


class FoosballEnv(gym.Env):
    """The home team's rods against a passive, scripted or frozen-policy away team."""

    metadata = {"render_modes": []}

    def __init__(self, reset: str = "paper", opponent: str = "none", config: Optional[EnvConfig] = None, **overrides):
        super().__init__()
        cfg = config or EnvConfig()
        cfg = EnvConfig(**{**cfg.__dict__, "reset": reset, "opponent": opponent, **overrides})
        self.config = cfg
        self.sim = TableSimulation(cfg.params_file)
        self.reset_task = make_reset(cfg.reset)
        self.opponent = make_opponent(cfg.opponent, self.sim, cfg.opponent_policy)
        self.reward_fn = cfg.reward
        steps_per_control = self.sim.timestep and round(1.0 / (cfg.control_rate * self.sim.timestep))
        if steps_per_control < CHUNK:
            raise ValueError(f"control_rate {cfg.control_rate} Hz is too fast for the {1 / self.sim.timestep:.0f} Hz physics")
        self.n_chunks = int(round(steps_per_control / CHUNK))
        self.dt = self.n_chunks * CHUNK * self.sim.timestep

        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (OBS_SIZE,), np.float32)
        self.action_space = gym.spaces.Box(-ACTION_LIMIT, ACTION_LIMIT, (COMMAND_SIZE,), np.float32)

        self._touching = dict.fromkeys(TEAMS, False)  # whether the ball touched the team's figures after the last chunk
        self.stats = EpisodeStats()
        self._stagnant_count = 0

    # --- gymnasium API --------------------------------------------------------------------------
    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        position, velocity = self.reset_task.sample(self.np_random, self.sim)
        initial_joints = getattr(self.opponent, "initial_joint_positions", None)
        self.sim.reset(ball_position=position, ball_velocity=velocity,
                       joint_positions=initial_joints() if initial_joints else None)
        self.stats = EpisodeStats(final_y=float(position[1]))
        self._touching = dict.fromkeys(TEAMS, False)
        self._stagnant_count = 0
        return self._observe("home"), {}

    def step(self, action):
        a = np.clip(np.asarray(action, dtype=np.float64).ravel(), -ACTION_LIMIT, ACTION_LIMIT)
        self.sim.set_command("home", action_to_command("home", a, self.sim.command_limits))
        away = self.opponent.act(self._observe("away"))
        if away is None:
            self.sim.stop_team("away")
        else:
            self.sim.set_command("away", action_to_command("away", away, self.sim.command_limits))

        y_before = float(self.sim.ball_position()[1])
        goal = self._advance()
        y_after = float(self.sim.ball_position()[1])
        unstable = not self.sim.state_is_finite()
        reward = self.reward_fn(y_before, y_after, goal, a, self.sim.half_length)

        speed = float(np.hypot(*self.sim.ball_velocity()[:2]))
        self._stagnant_count = self._stagnant_count + 1 if speed < self.config.stagnant_speed else 0
        stats = self.stats
        stats.length += 1
        stats.ret += reward
        stats.goal = goal
        stats.final_y = y_after
        stats.stagnant = self._stagnant_count >= self.config.stagnant_steps
        terminated = goal is not None or stats.stagnant or unstable
        truncated = (not terminated) and stats.length >= self.config.max_steps
        info: dict[str, Any] = {}
        if terminated or truncated:
            info["episode_stats"] = stats.summary()
            if unstable:
                info["episode_stats"]["unstable"] = 1.0
        obs = self._observe("home") if not unstable else np.zeros(OBS_SIZE, np.float32)
        return obs, reward, terminated, truncated, info

    # --- internals ------------------------------------------------------------------------------
    def _observe(self, team: str) -> np.ndarray:
        sim = self.sim
        return observe(team, sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())

    def _advance(self) -> Optional[str]:
        """One control step of chunks; the team that scored (the episode ends there), or None."""
        for _ in range(self.n_chunks):
            goal = self.sim.step(CHUNK)
            for team, touching in zip(TEAMS, self.sim.figure_contacts()):
                self._register_touch(team, touching)
            if goal is not None:
                return goal
        return None

    def _register_touch(self, team: str, touching: bool) -> None:
        """Counts a touch when the ball begins touching a team's figures."""
        if touching and not self._touching[team]:
            if team == "home":
                self.stats.touches_home += 1
                self.stats.last_home_touch_y = float(self.sim.ball_position()[1])
            else:
                self.stats.touches_away += 1
        self._touching[team] = touching


def make_env(reset: str = "paper", opponent: str = "none", opponent_policy: Optional[str] = None, **overrides) -> FoosballEnv:
    return FoosballEnv(reset=reset, opponent=opponent, opponent_policy=opponent_policy, **overrides)


__all__ = ["FoosballEnv", "EnvConfig", "EpisodeStats", "make_env"]
