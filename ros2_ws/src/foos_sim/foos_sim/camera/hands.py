"""A player's hand for the synthetic camera: it reaches in over the field, picks the ball up, and leaves.

The `play` rollout takes the ball out of sight now and then (`--hide-every`); on a real table a hand does
that, and a hand is a large, skin-coloured, moving blob that a tracker must not take for the ball. With
`render_video --hands` a hand and forearm (a palm, four fingers, a thumb and a forearm, in one skin tone)
comes in from the long side nearest the ball over HAND_REACH_TIME, covers the ball while it is picked up
(following the ball, as if carrying it), and goes back out over HAND_REACH_TIME after the ball is put
down. The hand's geoms only render: they do not collide and do not change the simulation, so a rollout
with and without hands is the same rollout.
"""
from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from typing import Optional

import numpy as np

HAND_BODY = "vision_hand"
# A medium skin tone (linear RGB of the material, before the scene's lights): its hue lies between the red and
# the orange ball's, and it is far less saturated than either.
SKIN_RGB = (0.80, 0.58, 0.45)
HAND_REACH_TIME = 0.2  # s: in from outside the table to over the ball (and back out)
HOLD_HEIGHT = 0.055  # m: palm centre above the surface while it holds the ball (the ball's top is at 0.035)
OUTSIDE = (0.70, 0.35)  # m: |x| and z where the hand starts and ends, off the long side and above the rods
AWAY_Z = -5.0  # where the hand waits, out of every camera's view (below the room floor)


@dataclass(frozen=True)
class HandPose:
    position: np.ndarray  # (3,) palm centre, table frame
    side: float  # +1: the player stands at +x (the fingers point toward -x), -1 the other side

    @property
    def quat(self) -> np.ndarray:
        """MuJoCo (w, x, y, z): the body's +x (toward the fingertips) points into the table."""
        return np.array([1.0, 0.0, 0.0, 0.0]) if self.side < 0 else np.array([0.0, 0.0, 0.0, 1.0])


def add_hand(world: ET.Element, asset: ET.Element) -> None:
    """A mocap hand and forearm (body HAND_BODY), in the body frame: origin at the palm centre, +x toward the
    fingertips, +z up. Sizes of an adult hand: palm 9 x 8.5 cm, fingers 7 cm, forearm 6.6 cm thick."""
    ET.SubElement(asset, "material", name="vision_skin", rgba=f"{SKIN_RGB[0]} {SKIN_RGB[1]} {SKIN_RGB[2]} 1",
                  specular="0.15", shininess="0.2")
    body = ET.SubElement(world, "body", name=HAND_BODY, mocap="true", pos=f"0 0 {AWAY_Z}")
    common = {"material": "vision_skin", "contype": "0", "conaffinity": "0", "group": "1"}
    ET.SubElement(body, "geom", name="vision_palm", type="ellipsoid", size="0.045 0.042 0.014", **common)
    for i, y in enumerate((-0.027, -0.009, 0.009, 0.027)):
        length = 0.07 if i in (1, 2) else 0.06
        ET.SubElement(body, "geom", name=f"vision_finger{i}", type="capsule", size="0.0085",
                      fromto=f"0.035 {y} 0 {0.035 + length} {y} -0.012", **common)
    ET.SubElement(body, "geom", name="vision_thumb", type="capsule", size="0.0105",
                  fromto="0.0 0.038 -0.002 0.045 0.068 -0.012", **common)
    ET.SubElement(body, "geom", name="vision_forearm", type="capsule", size="0.033",
                  fromto="-0.045 0 0.006 -0.30 0 0.15", **common)


def _smooth(s: float) -> float:
    s = min(1.0, max(0.0, s))
    return s * s * (3 - 2 * s)


class HandScript:
    """Where the hand is at time t, from a SimRollout's pick-up schedule (call after rollout.state_at(t)).

    Approach: over the HAND_REACH_TIME before a pick-up, from outside the nearest long side to over the ball.
    Hold: while the ball is out of sight, over the (hidden) ball. Retreat: over the HAND_REACH_TIME after it is
    put down, from where it was let go back outside. Otherwise the hand is away (None)."""

    def __init__(self, rollout):
        self.rollout = rollout
        self._event: Optional[float] = None  # the pick-up time of the current approach
        self._side = 1.0
        self._released: Optional[np.ndarray] = None  # palm position when the ball was put down

    def _outside(self, y: float) -> np.ndarray:
        return np.array([self._side * OUTSIDE[0], y, OUTSIDE[1]])

    def pose(self, t: float, ball: np.ndarray) -> Optional[HandPose]:
        r = self.rollout
        over = np.array([ball[0], ball[1], HOLD_HEIGHT])
        if t < r.hidden_until:
            self._released = over
            return HandPose(over, self._side)
        if math.isfinite(r.next_hide) and t >= r.next_hide - HAND_REACH_TIME:
            if self._event != r.next_hide:
                self._event = r.next_hide
                self._side = 1.0 if ball[0] >= 0 else -1.0
            s = _smooth((t - (r.next_hide - HAND_REACH_TIME)) / HAND_REACH_TIME)
            start = self._outside(ball[1])
            return HandPose(start + s * (over - start), self._side)
        if self._released is not None and t < r.hidden_until + HAND_REACH_TIME:
            s = _smooth((t - r.hidden_until) / HAND_REACH_TIME)
            end = self._outside(self._released[1])
            return HandPose(self._released + s * (end - self._released), self._side)
        return None
