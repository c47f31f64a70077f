"""A curriculum in front of the task a policy is trained for: a resting ball and still opponents first.

Against the scripted goalie and defence, a learner that cannot yet reach the ball sees almost no goal, and
its first goals are rare enough that its critic learns little from them. The stages below put the same
serve-free placements first on a still ball, then on the task's own serve, with the away rods standing
still, and only then the task itself; the last stage is always exactly the task asked for, so every
evaluation of the policy is on that task.
"""
from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Stage:
    until: float        # share of the training budget (steps or wall-clock, whichever runs out first) it lasts to
    reset: str
    opponent: str


def stages(reset: str, opponent: str, enabled: bool) -> tuple[Stage, ...]:
    """The curriculum ending in the task (reset, opponent); just the task when not enabled."""
    task = Stage(1.0, reset, opponent)
    if not enabled:
        return (task,)
    return (Stage(0.15, "resting", "none"), Stage(0.30, reset, "none"), task)


def stage_at(curriculum: tuple[Stage, ...], progress: float) -> Stage:
    """The stage in force at `progress` (0..1) of the budget."""
    for stage in curriculum:
        if progress < stage.until:
            return stage
    return curriculum[-1]
