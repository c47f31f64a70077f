"""Tasks on top of the table model, dm_control style: a reset (serve), a reward, and an opponent.

The env (foos_policy.env) owns the simulation and the episode bookkeeping; these small objects say how
an episode starts, what it pays and who plays the away rods.
"""
from __future__ import annotations

from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Optional, Protocol

import numpy as np

from foos_core.names import JOINT_NAMES

from .policies import ModelPolicy
from .scripted import ScriptedPolicy

RESETS = ("paper", "hardened", "resting")
REWARDS = ("paper", "skill")
OPPONENTS = ("none", "scripted", "selfplay", "lifted")


# --- resets -------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PaperServe:
    """The paper's reset: ball at the centre, served toward +y at a random speed up to max_speed."""

    max_speed: float = 15.0        # m/s
    lateral_speed: float = 0.5     # m/s, half-width of the uniform lateral noise
    lateral_offset: float = 0.005  # m, half-width of the uniform x noise of the spot

    def sample(self, rng: np.random.Generator, sim) -> tuple[np.ndarray, np.ndarray]:
        position = np.array([rng.uniform(-self.lateral_offset, self.lateral_offset), 0.0])
        velocity = np.array([rng.uniform(-self.lateral_speed, self.lateral_speed), rng.uniform(0.0, self.max_speed)])
        return position, velocity


@dataclass(frozen=True)
class HardenedPlacement:
    """Ball nearly still at a random spot in front of one of the home outfield rods: a goal needs a touch.

    The spot is drawn uniformly in x within max_abs_x and in y within a strip `front` ahead of the
    home defence, midfield or attack rod (one of the three at random), where a swinging foot reaches
    it; elsewhere a still ball lies in a dead zone that no home figure can reach, and the episode
    would only wait for stagnation. With speed <= max_speed (0.2 m/s rolls at most 0.13 m at
    0.15 m/s^2) the ball stays more than 0.25 m from either goal line, and the goalie is left out so
    no episode starts next to a goal.
    """

    max_abs_x: float = 0.30
    max_speed: float = 0.20
    front: tuple[float, float] = (0.035, 0.080)   # m ahead of the rod axis (toward +y)
    rods: tuple[str, ...] = ("defence", "midfield", "attack")

    def sample(self, rng: np.random.Generator, sim) -> tuple[np.ndarray, np.ndarray]:
        layout = sim.params["rods"]["layout"]
        rod_y = float(layout[f"home_{self.rods[rng.integers(len(self.rods))]}"]["y"])
        x = rng.uniform(-self.max_abs_x, self.max_abs_x)
        y = rod_y + rng.uniform(*self.front)
        speed = rng.uniform(0.0, self.max_speed)
        heading = rng.uniform(-np.pi, np.pi)
        return np.array([x, y]), speed * np.array([np.cos(heading), np.sin(heading)])


def make_reset(name: str):
    if name == "paper":
        return PaperServe()
    if name == "hardened":
        return HardenedPlacement()
    if name == "resting":
        return HardenedPlacement(max_speed=0.0)
    raise ValueError(f"unknown reset `{name}` (expected one of {RESETS})")


# --- reward --------------------------------------------------------------------------------------
@dataclass(frozen=True)
class PaperReward:
    """R = 50 max(dy, 0) + 5 / (1 + |y_virtual - y|) + 1000 [home goal] - 1000 [own goal] - c |a|^2.

    y in metres, own view; the virtual goal sits at `virtual_goal_fraction` of the half length toward
    the opponent's goal; a is the action in the paper's [-20, 20] units.
    """

    progress_weight: float = 50.0
    proximity_weight: float = 5.0
    goal_reward: float = 1000.0
    virtual_goal_fraction: float = 0.8
    control_cost: float = 1e-4

    def __call__(self, y_before: float, y_after: float, goal: Optional[str], action, half_length: float,
                 first_touch: bool = False, spun_touches: int = 0, goal_spun: bool = False) -> float:
        y_virtual = self.virtual_goal_fraction * half_length
        reward = self.progress_weight * max(y_after - y_before, 0.0)
        reward += self.proximity_weight / (1.0 + abs(y_virtual - y_after))
        if goal == "home":
            reward += self.goal_reward
        elif goal == "away":
            reward -= self.goal_reward
        a = np.asarray(action, dtype=float)
        reward -= self.control_cost * float(a @ a)
        return float(reward)


@dataclass(frozen=True)
class SkillReward:
    """R = w_p (y_after - y_before) + w_t [first home touch] + G [home goal] - G_own [own goal], in units a
    SAC critic learns well (returns of order 10, not 1000).

    The progress term is signed, so it is potential-based shaping (potential w_p y): over an episode it sums
    to w_p times the ball's net gain, and it cannot change which policy is best; it only tells the learner
    sooner that a kick forward was good and that a ball sent back toward its own goal was not. The paper's
    max(dy, 0) pays a ball that goes forward and back again twice. The touch bonus is paid once per episode,
    for the first touch of a home figure: on a resting ball nothing else rewards reaching it.

    With a spin penalty the tournament rule on spins holds (foos_policy.spins): each home touch by a rod that
    had turned more than a full turn one way costs the penalty, and a home goal off such a touch pays no goal
    reward, as a referee would not count it. Without it (0, the default) spins are free, as they were.
    """

    progress_weight: float = 5.0        # per metre gained toward the opponent's goal
    touch_bonus: float = 0.5
    goal_reward: float = 10.0
    own_goal_penalty: float = 10.0
    spin_penalty: float = 0.0

    def __call__(self, y_before: float, y_after: float, goal: Optional[str], action, half_length: float,
                 first_touch: bool = False, spun_touches: int = 0, goal_spun: bool = False) -> float:
        reward = self.progress_weight * (y_after - y_before)
        if first_touch:
            reward += self.touch_bonus
        reward -= self.spin_penalty * spun_touches
        if goal == "home":
            if not (self.spin_penalty > 0 and goal_spun):
                reward += self.goal_reward
        elif goal == "away":
            reward -= self.own_goal_penalty
        return float(reward)


def make_reward(name: str, own_goal_penalty: Optional[float] = None, spin_penalty: Optional[float] = None):
    """The named reward; `own_goal_penalty` overrides the skill reward's (the paper's is its goal reward), and
    `spin_penalty` puts the skill reward under the tournament rule on spins."""
    changes = {}
    for field, article, what, value in (("own_goal_penalty", "an", "own-goal penalty", own_goal_penalty),
                                        ("spin_penalty", "a", "spin penalty", spin_penalty)):
        if value is None:
            continue
        if name != "skill":
            raise ValueError(f"{article} {what} applies to the skill reward only, not `{name}`")
        if not value >= 0:
            raise ValueError(f"the {what} must be at least 0, got {value}")
        changes[field] = float(value)
    if name == "paper":
        return PaperReward()
    if name == "skill":
        return SkillReward(**changes)
    raise ValueError(f"unknown reward `{name}` (expected one of {REWARDS})")


# --- opponents -----------------------------------------------------------------------------------
class Opponent(Protocol):
    def act(self, obs: np.ndarray) -> Optional[np.ndarray]:
        """An own-view action for the away team, or None to leave its drives stopped."""


class PassiveOpponent:
    """The paper's setting: the away rods stand still, hanging, centred."""

    def act(self, obs: np.ndarray) -> Optional[np.ndarray]:
        return None


class LiftedOpponent:
    """A diagnostic: every away rod horizontal, out of play from the first step, so nothing stands in the
    serve's way (how an empty opponent half lets the paper's serve score)."""

    def __init__(self, params: dict, command_limits):
        self.policy = ScriptedPolicy(params, command_limits, active=())

    def initial_joint_positions(self) -> np.ndarray:
        # own view +pi/2 (ScriptedPolicy.LIFTED) is -pi/2 in the table frame for the mirrored away team
        return np.array([-np.pi / 2 if n.startswith("away_") and n.endswith("_rotate") else 0.0 for n in JOINT_NAMES])

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy.predict(obs)


class ScriptedOpponent:
    """A goalie and defence that track the ball and clear it; the away midfield and attack are lifted."""

    def __init__(self, params: dict, command_limits):
        self.policy = ScriptedPolicy(params, command_limits, active=("goalie", "defence"))

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy.predict(obs)


class FrozenPolicyOpponent:
    """Self-play: a saved SB3 policy plays the away rods through the mirrored observation (velocity actions,
    or position targets followed by their controller, as ModelPolicy plays either)."""

    def __init__(self, path: str | Path, params: dict, command_limits):
        self.policy = ModelPolicy(path, params, command_limits)

    def clear(self) -> None:
        """A new episode: a decision held from the last one is dropped (foos_policy.decisions)."""
        self.policy.reset()

    def act(self, obs: np.ndarray) -> np.ndarray:
        return self.policy.predict(obs)


class ReactionDelay:
    """An opponent acting on its observation of `steps` control steps ago: a real table's camera and drive
    dead time, which the scripted opponent otherwise lacks (it sees the true state at once)."""

    def __init__(self, opponent: Opponent, steps: int):
        self.opponent = opponent
        self.steps = int(steps)
        self.seen: deque = deque(maxlen=self.steps + 1)
        initial = getattr(opponent, "initial_joint_positions", None)
        if initial is not None:
            self.initial_joint_positions = initial

    def clear(self) -> None:
        """Forget what was seen: a new episode starts from what it shows."""
        self.seen.clear()
        if hasattr(self.opponent, "clear"):
            self.opponent.clear()

    def act(self, obs: np.ndarray) -> Optional[np.ndarray]:
        self.seen.append(np.array(obs))
        return self.opponent.act(self.seen[0])


def make_opponent(name: str, sim, opponent_policy: str | None = None, delay_steps: int = 0) -> Opponent:
    """The away team `name`, acting `delay_steps` control steps late when that is above 0."""
    if delay_steps < 0:
        raise ValueError(f"the opponent's delay must not be negative, got {delay_steps} steps")
    opponent = _make_opponent(name, sim, opponent_policy)
    return ReactionDelay(opponent, delay_steps) if delay_steps > 0 else opponent


def _make_opponent(name: str, sim, opponent_policy: str | None) -> Opponent:
    if name == "none":
        return PassiveOpponent()
    if name == "scripted":
        return ScriptedOpponent(sim.params, sim.command_limits)
    if name == "lifted":
        return LiftedOpponent(sim.params, sim.command_limits)
    if name == "selfplay":
        if not opponent_policy:
            raise ValueError("--opponent selfplay needs --opponent-policy PATH.zip (the frozen policy)")
        return FrozenPolicyOpponent(opponent_policy, sim.params, sim.command_limits)
    raise ValueError(f"unknown opponent `{name}` (expected one of {OPPONENTS})")
