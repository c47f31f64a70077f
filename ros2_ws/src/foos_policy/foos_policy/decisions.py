"""Decisions held over several control steps (`train --decision-period K`).

Why: a learner that picks a new correction every 20 ms control step sees each one's effect on the ball drowned in the
next ones' and in its own exploration noise; its learning curves stayed flat in every round on the robot table
(docs/measurements/policy-2026-11-28-lift-ahead-6.md). Holding the learner's action for K control steps makes each
decision act for K x 20 ms, and its exploration noise coherent over that time, while whatever turns the action into
velocity commands (the scripted base under corrections, the braking-curve controller under position targets) still
runs every control step on the newest observation. The learner then sees one transition per decision, its reward
the sum over the held steps; its discount `gamma` is per decision.

`DecisionPeriod` is the learner's side (train), `HeldDecision` the trained policy's (evaluate, policy_node, games):
both hold an action for `period` control steps from an episode's first step.
"""
from __future__ import annotations

import gymnasium as gym

DECISION_PERIOD_DEFAULT = 1  # a decision every control step: every model saved before this option existed


def check_decision_period(period) -> int:
    if isinstance(period, bool) or not isinstance(period, int) or period < 1:
        raise ValueError(f"the decision period must be a whole number of control steps >= 1, got {period!r}")
    return period


class HeldDecision:
    """Counts an episode's control steps: `due()` is true on its first step and every `period` steps after it."""

    def __init__(self, period: int):
        self.period = check_decision_period(period)
        self.reset()

    def reset(self) -> None:
        self.steps = 0  # control steps of this episode so far

    def due(self) -> bool:
        due = self.steps % self.period == 0
        self.steps += 1
        return due


class DecisionPeriod(gym.Wrapper):
    """The learner's view of an env whose actions are held for `period` control steps: one `step` plays the action
    until the next decision is due or the episode ends, and returns the summed reward and the last observation and
    info (where a finished episode's `episode_stats` are)."""

    def __init__(self, env, period: int):
        super().__init__(env)
        self.period = check_decision_period(period)
        self.control_steps = 0  # what the learner's step count is not: the env's own steps

    def step(self, action):
        total = 0.0
        for _ in range(self.period):
            obs, reward, terminated, truncated, info = self.env.step(action)
            self.control_steps += 1
            total += float(reward)
            if terminated or truncated:
                break
        return obs, total, terminated, truncated, info
