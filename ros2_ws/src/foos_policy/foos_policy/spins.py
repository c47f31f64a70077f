"""Spins, as the tournament rules count them: how far a rod has turned one way before its figure strikes (ROS-free).

Under the ITSF rules (and the US ones) a figure may turn less than 360 degrees before it strikes the ball and less
than 360 degrees after; more is a spin, and a spun shot does not count. A robot's drive can whirl a rod at 300
rad/s, and the policies trained on the robot table do: the 28 Nov evaluation found the shipped SAC's own goals
came from a defence rod turning backwards at about 290 rad/s, whose feet strike a still ball in front of it
at 15 m/s toward its own goal. Counting spins says how much of a policy's play (and of its own goals) a real
referee would not allow.

A sweep is the rod's turn in one direction since it last reversed or stood still. The angles are sampled once a
control step (20 ms at 50 Hz), so a reversal inside a step is missed, and a sweep then counts from the step before.
"""
from __future__ import annotations

import numpy as np

FULL_TURN = 2.0 * np.pi     # rad: a sweep beyond this before a strike is a spin
STILL_PER_STEP = 0.02       # rad: a rod that turns less in a control step (1 rad/s at 50 Hz) stands still


class SweepTracker:
    """Per rod, the angle turned in one direction since the rod last reversed or stood still, and its total turn."""

    def __init__(self, angles) -> None:
        self.reset(angles)

    def reset(self, angles) -> None:
        """Start afresh at `angles` (unwrapped, rad): no sweep and no turn yet."""
        self.last = np.array(angles, dtype=float)
        self.start = self.last.copy()
        self.turned = np.zeros_like(self.last)

    def update(self, angles) -> None:
        """The rods' unwrapped angles one control step later."""
        angles = np.asarray(angles, dtype=float)
        step = angles - self.last
        sweep = self.last - self.start
        reversed_ = (sweep != 0.0) & (np.sign(step) != np.sign(sweep))
        still = np.abs(step) < STILL_PER_STEP
        self.start = np.where(reversed_ | still, self.last, self.start)
        self.turned += np.abs(step)
        self.last = angles.copy()

    def swept(self) -> np.ndarray:
        """Each rod's sweep so far (rad, at least 0)."""
        return np.abs(self.last - self.start)

    def spinning(self) -> np.ndarray:
        """Whether each rod has turned more than a full turn one way: a strike now would be a spin."""
        return self.swept() > FULL_TURN
