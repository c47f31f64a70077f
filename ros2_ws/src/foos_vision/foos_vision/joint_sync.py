"""Pairs live camera frames with rod joint readings by stamp (tracker_node's figure mask).

Why frames are held: a frame must be masked with the rods' pose at its own capture time, and the reading
for that time can arrive after the frame (the encoders' messages take another path; an executor that is
behind takes one message per topic per turn, so the joint queue falls behind the image queue as soon as
images are dropped). Using "the latest reading" then masks a figure where it was frames ago, or not at
all, and a red figure passes for a red ball. So a frame newer than every reading waits until a reading
at or after its stamp arrives (then the pose is interpolated to the stamp), but never longer than
`max_hold` seconds of frame stamps, nor `max_wait_wall` seconds of wall time: the mask is an aid, a frame
is never dropped for it, and a table without encoders never waits at all.

ROS-free: plain Python and numpy.
"""
from __future__ import annotations

import bisect
from collections import deque
from dataclasses import dataclass
from typing import Any, Callable, Optional

import numpy as np

JOINT_STATE_MAX_AGE = 0.1  # s: an older reading no longer says where a kicking figure is
MAX_HOLD = 0.1  # s of frame stamps a frame may wait for its reading (the latency the mask may add)
MAX_WAIT_WALL = 0.25  # s of wall time a frame may wait (the readings stopped, or the stream did)
STOPPED = 1.0  # s: a frame this much newer than the latest reading does not wait (encoders unplugged)


@dataclass
class ReadyFrame:
    stamp: float
    payload: Any
    joints: Optional[np.ndarray]  # the 16 joint positions at the stamp; None: no mask for this frame


class JointSync:
    """Joint readings (a short history, by stamp) and the frames waiting for theirs."""

    def __init__(self, max_age: float = JOINT_STATE_MAX_AGE, max_hold: float = MAX_HOLD,
                 max_wait_wall: float = MAX_WAIT_WALL, history: int = 600):
        self.max_age, self.max_hold, self.max_wait_wall = max_age, max_hold, max_wait_wall
        self._stamps: deque = deque(maxlen=history)
        self._positions: deque = deque(maxlen=history)
        self._pending: deque = deque()  # (stamp, payload, wall time it arrived), in arrival order
        self.unmatched = 0  # frames let go before their reading came (readings late or stopped)

    @property
    def latest_stamp(self) -> Optional[float]:
        return self._stamps[-1] if self._stamps else None

    def add_joints(self, stamp: float, positions: np.ndarray) -> list[ReadyFrame]:
        """Records a reading; the waiting frames it covers, in order."""
        if self._stamps and stamp < self._stamps[-1]:
            self._stamps.clear()  # time went backwards (a bag replayed again): start over
            self._positions.clear()
        if self._stamps and stamp == self._stamps[-1]:
            self._positions[-1] = positions  # a repeated stamp: the newer reading wins
        else:
            self._stamps.append(stamp)
            self._positions.append(positions)
        return self._release(lambda t, arrived: self._covered(t))

    def add_frame(self, stamp: float, payload: Any, wall: float) -> list[ReadyFrame]:
        """A new frame; the frames ready now, in order (this one too when its reading is there, or when
        no recent joint reading was seen: a table without encoders)."""
        if self._pending and stamp < self._pending[-1][0]:
            # Stamps went backwards (a replay restarted): what waits belongs to the old run.
            ready = self.flush()
        else:
            ready = []
        self._pending.append((stamp, payload, wall))
        if not self._stamps or stamp - self._stamps[-1] > STOPPED:
            return ready + self.flush()
        return ready + self._release(lambda t, arrived: self._covered(t) or stamp - t > self.max_hold)

    def due(self, wall: float) -> list[ReadyFrame]:
        """Frames that have waited longer than max_wait_wall (call it from a timer)."""
        return self._release(lambda t, arrived: wall - arrived > self.max_wait_wall)

    def flush(self) -> list[ReadyFrame]:
        return self._release(lambda t, arrived: True)

    def joints_at(self, t: float) -> Optional[np.ndarray]:
        """The joint positions at t: interpolated between the readings around it, else the latest reading
        at or before t if at most max_age older (None: no mask)."""
        stamps = self._stamps
        i = bisect.bisect_right(stamps, t + 1e-6)
        if i == 0 or t - stamps[i - 1] > self.max_age:
            return None
        before, q_before = stamps[i - 1], self._positions[i - 1]
        if i < len(stamps) and stamps[i] - before <= self.max_age and stamps[i] > before:
            w = (t - before) / (stamps[i] - before)
            return (1 - w) * q_before + w * self._positions[i]
        return q_before

    def _covered(self, t: float) -> bool:
        return bool(self._stamps) and self._stamps[-1] >= t - 1e-6

    def _release(self, ready_if: Callable[[float, float], bool]) -> list[ReadyFrame]:
        # Frames leave in order: the first one that must still wait keeps the later ones waiting too.
        out = []
        while self._pending and ready_if(self._pending[0][0], self._pending[0][2]):
            stamp, payload, _ = self._pending.popleft()
            if self._stamps and not self._covered(stamp):
                self.unmatched += 1
            out.append(ReadyFrame(stamp, payload, self.joints_at(stamp)))
        return out
