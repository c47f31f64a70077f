"""FoosballEnv: the paper's task on the foos_sim table as a gymnasium env (ROS-free).

    env = FoosballEnv(reset="hardened", opponent="scripted")
    obs, info = env.reset(seed=0)
    obs, reward, terminated, truncated, info = env.step(env.action_space.sample())

Control runs at `control_rate` Hz (50 by default) over the table's physics (foos_sim's fast physics
unless the parameter file names the reference): one control step is one TableSimulation.advance(1 /
control_rate). The episode ends at the control step in which the simulation reports a goal, and every
rod-ball touch is counted: the simulation counts the touches of each team's figures as they begin.

The home action is the paper's velocity action, or with `action="position"` rod position targets in
[-1, 1]^8, or with `action="residual"` corrections to the scripted controller, that foos_policy.actions turns
into it at each step.

Both teams see the ball as a real table's camera loop delivers it (foos_policy.camera_view: 40 ms late,
1.5 mm and 0.05 m/s of noise), and their own rods' joints at once; `view` / `opponent_view` "instant" give
a team the true state at once instead. Goals, rewards and the episode's end are judged on the true state.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any, Optional

import gymnasium as gym
import numpy as np

from foos_core.names import COMMAND_SIZE, JOINT_NAMES, RODS
from foos_sim.simulation import TableSimulation

from .actions import action_high, action_map
from .camera_view import CAMERA_LATENCY, POSITION_NOISE, VELOCITY_NOISE, VIEWS, CameraView
from .observation import ACTION_LIMIT, OBS_SIZE, action_to_command, observe
from .spins import FULL_TURN, SweepTracker
from .tasks import make_opponent, make_reset, make_reward


@dataclass
class EnvConfig:
    reset: str = "paper"                # paper | hardened
    opponent: str = "none"              # none | scripted | selfplay | lifted
    opponent_policy: Optional[str] = None
    opponent_delay: float = 0.0         # s, the away team acts on what it saw this long ago (whole control steps)
    control_rate: float = 50.0          # Hz
    max_steps: int = 500                # time limit: 10 s at 50 Hz
    stagnant_speed: float = 0.05        # m/s, planar ball speed under which the ball counts as stagnant
    stagnant_steps: int = 50            # control steps (1 s at 50 Hz) of stagnation that end an episode
    params_file: Optional[str] = None
    reward: str = "paper"               # paper | skill (foos_policy.tasks.REWARDS)
    own_goal_penalty: Optional[float] = None  # the skill reward's, when not its default
    spin_penalty: Optional[float] = None      # the skill reward's cost of a spun home touch (foos_policy.spins)
    view: str = "camera"                # camera | instant: how the home policy sees the ball (camera_view)
    opponent_view: str = "camera"       # camera | instant: the same for the away team
    camera_latency: float = CAMERA_LATENCY    # s
    camera_noise: float = POSITION_NOISE      # m per axis; the velocity's noise is VELOCITY_NOISE while this is > 0
    action: str = "velocity"            # velocity | position | residual: what the home action asks of the rods (foos_policy.actions)
    residual_base: str = "scripted"     # scripted | lift-ahead: what `residual` corrections act on (foos_policy.actions)
    action_cost: float = 0.0            # per step, times the mean of (action / its bound)^2: keeps corrections near their base


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
    last_home_touch_rod: Optional[str] = None  # the home rod nearest the ball when home last began touching it
    last_toucher: Optional[str] = None  # home | away | both (began in the same control step) | None
    home_touches_spun: int = 0          # home touches by a rod that had turned more than a full turn one way (spins)
    last_home_touch_spun: bool = False
    home_turns: float = 0.0             # full turns of the four home rods together, set when the episode ends
    final_y: float = 0.0
    task: str = ""                      # reset/opponent the episode was played on

    @property
    def last_touch_spun(self) -> bool:
        """Whether the ball's last touch was a home spin (a home goal then does not count under the rule)."""
        return self.last_toucher == "home" and self.last_home_touch_spun

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
            # who touched the ball last before a goal against: the policy's own rods, or the opponent's shot
            "own_goal_last_touch": (self.last_toucher or "none") if self.goal == "away" else "",
            "own_goal_home_rod": (self.last_home_touch_rod or "") if self.goal == "away" and self.last_toucher == "home" else "",
            # spins (foos_policy.spins): what a referee would not allow
            "home_touches_spun": self.home_touches_spun,
            "own_goal_off_spin": float(self.goal == "away" and self.last_touch_spun),
            "goal_off_spin": float(self.goal == "home" and self.last_touch_spun),
            "home_turns": self.home_turns,
            "task": self.task,
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
        self.reward_fn = make_reward(cfg.reward, cfg.own_goal_penalty, cfg.spin_penalty)
        if not cfg.action_cost >= 0:
            raise ValueError(f"the action cost must be at least 0, got {cfg.action_cost}")
        if not cfg.control_rate > 0 or 1.0 / cfg.control_rate < self.sim.timestep:
            raise ValueError(f"control_rate {cfg.control_rate} Hz is not within the {1 / self.sim.timestep:.0f} Hz physics")
        self.dt = 1.0 / cfg.control_rate
        if not cfg.opponent_delay >= 0:
            raise ValueError(f"the opponent's delay must be at least 0 s, got {cfg.opponent_delay}")
        self.opponent_delay_steps = int(round(cfg.opponent_delay / self.dt))
        self.opponent = make_opponent(cfg.opponent, self.sim, cfg.opponent_policy, self.opponent_delay_steps)
        for name in ("view", "opponent_view"):
            if getattr(cfg, name) not in VIEWS:
                raise ValueError(f"{name} must be one of {', '.join(VIEWS)}, got '{getattr(cfg, name)}'")
        self.camera = CameraView(cfg.camera_latency, cfg.camera_noise, VELOCITY_NOISE if cfg.camera_noise > 0 else 0.0)
        self._views = {"home": cfg.view, "away": cfg.opponent_view}

        high = action_high(cfg.action).astype(np.float32)
        self.action_map = action_map(cfg.action, self.sim.params, self.sim.command_limits, cfg.residual_base)

        self.observation_space = gym.spaces.Box(-np.inf, np.inf, (OBS_SIZE,), np.float32)
        self.action_space = gym.spaces.Box(-high, high, (COMMAND_SIZE,), np.float32)
        self._home_obs = np.zeros(OBS_SIZE, np.float32)  # what the home policy saw last: its action answers it

        self.stats = EpisodeStats()
        self._stagnant_count = 0
        # The home rods in RODS order: their names, y and rotation joints (a touch is put down to the nearest rod)
        self._home_rods = [f"home_{rod}" for rod in RODS]
        self._home_rod_y = np.array([float(self.sim.params["rods"]["layout"][name]["y"]) for name in self._home_rods])
        self._home_rotations = np.array([JOINT_NAMES.index(f"{name}_rotate") for name in self._home_rods])
        self.sweeps = SweepTracker(np.zeros(len(RODS)))

    # --- gymnasium API --------------------------------------------------------------------------
    def reset(self, *, seed: Optional[int] = None, options: Optional[dict] = None):
        super().reset(seed=seed)
        if hasattr(self.opponent, "clear"):
            self.opponent.clear()
        position, velocity = self.reset_task.sample(self.np_random, self.sim)
        initial_joints = getattr(self.opponent, "initial_joint_positions", None)
        self.sim.reset(ball_position=position, ball_velocity=velocity,
                       joint_positions=initial_joints() if initial_joints else None)
        self.camera.clear()
        self.sweeps.reset(self.sim.joint_positions()[self._home_rotations])
        self._film()
        self.stats = EpisodeStats(final_y=float(position[1]), task=f"{self.config.reset}/{self.config.opponent}")
        self._stagnant_count = 0
        self._home_obs = self._observe("home")
        return self._home_obs, {}

    def step(self, action):
        # the cost is on what the policy chose, in its own box, before it becomes a velocity (none by default)
        cost = 0.0
        if self.config.action_cost:
            cost = self.config.action_cost * float(np.mean(np.square(np.asarray(action, dtype=float).ravel() / self.action_space.high)))
        if self.action_map is not None:  # position targets or corrections -> this step's velocity action
            action = self.action_map.velocity_action(self._home_obs, action)
        a = np.clip(np.asarray(action, dtype=np.float64).ravel(), -ACTION_LIMIT, ACTION_LIMIT)
        self.sim.set_command("home", action_to_command("home", a, self.sim.command_limits))
        away = self.opponent.act(self._observe("away"))
        if away is None:
            self.sim.stop_team("away")
        else:
            self.sim.set_command("away", action_to_command("away", away, self.sim.command_limits))

        y_before = float(self.sim.ball_position()[1])
        touched_before = self.stats.touches_home > 0
        spun_before = self.stats.home_touches_spun
        goal = self._advance()
        self._film()
        y_after = float(self.sim.ball_position()[1])
        unstable = not self.sim.state_is_finite()
        first_touch = not touched_before and self.stats.touches_home > 0
        reward = self.reward_fn(y_before, y_after, goal, a, self.sim.half_length, first_touch=first_touch,
                                spun_touches=self.stats.home_touches_spun - spun_before,
                                goal_spun=self.stats.last_touch_spun) - cost

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
            stats.home_turns = float(self.sweeps.turned.sum() / FULL_TURN)
            info["episode_stats"] = stats.summary()
            if unstable:
                info["episode_stats"]["unstable"] = 1.0
        obs = self._home_obs = self._observe("home") if not unstable else np.zeros(OBS_SIZE, np.float32)
        return obs, reward, terminated, truncated, info

    def set_task(self, reset: Optional[str] = None, opponent: Optional[str] = None) -> None:
        """Change the serve or the opponent from the next episode on (a curriculum's stages)."""
        if reset is not None and reset != self.config.reset:
            self.reset_task = make_reset(reset)
            self.config.reset = reset
        if opponent is not None and opponent != self.config.opponent:
            self.opponent = make_opponent(opponent, self.sim, self.config.opponent_policy, self.opponent_delay_steps)
            self.config.opponent = opponent

    # --- internals ------------------------------------------------------------------------------
    def _film(self) -> None:
        """The camera's frame of the ball now (the loop delivers it `camera_latency` later)."""
        sim = self.sim
        self.camera.record(sim.time, sim.ball_position(), sim.ball_velocity(), self.np_random)

    def _observe(self, team: str) -> np.ndarray:
        sim = self.sim
        if self._views[team] == "camera":
            position, velocity = self.camera.ball()
        else:
            position, velocity = sim.ball_position(), sim.ball_velocity()
        return observe(team, position, velocity, sim.joint_positions(), sim.joint_velocities())

    def _advance(self) -> Optional[str]:
        """One control step of physics; the team that scored (the episode ends there), or None. The touches
        that began in it are counted, and where the ball was at the last home touch."""
        home_before, away_before = self.sim.figure_touches()
        goal = self.sim.advance(self.dt)
        home, away = self.sim.figure_touches()
        self.stats.touches_home += home - home_before
        self.stats.touches_away += away - away_before
        self.sweeps.update(self.sim.joint_positions()[self._home_rotations])
        if home > home_before:
            y = self.stats.last_home_touch_y = float(self.sim.last_touch_ball_position("home")[1])
            rod = int(np.argmin(np.abs(self._home_rod_y - y)))
            self.stats.last_home_touch_rod = self._home_rods[rod]
            spun = self.stats.last_home_touch_spun = bool(self.sweeps.spinning()[rod])
            self.stats.home_touches_spun += (home - home_before) if spun else 0
        if home > home_before or away > away_before:
            self.stats.last_toucher = "both" if (home > home_before and away > away_before) else ("home" if home > home_before else "away")
        return goal


def make_env(reset: str = "paper", opponent: str = "none", opponent_policy: Optional[str] = None, **overrides) -> FoosballEnv:
    return FoosballEnv(reset=reset, opponent=opponent, opponent_policy=opponent_policy, **overrides)


__all__ = ["FoosballEnv", "EnvConfig", "EpisodeStats", "make_env"]
