"""The live scene served over a Foxglove WebSocket: the latest table state in, rate-limited scene updates out.

No ROS here: scene_node feeds it from the contract's topics, and a test can feed it directly.

    live = LiveScene(TableScene(params_file), host="127.0.0.1", port=8765, max_rate=30.0)
    live.set_joints(names, positions, stamp)     # /joint_states
    live.set_ball(position, velocity, stamp)     # /ball/state
    live.add_detection(position, stamp)          # /ball/detection
    live.flush()                                 # on a timer: sends what a rate limit held back
    live.close()

Each kind of entity has its own topic (a Foxglove user can hide one), each sent at most max_rate times a
second; an update that arrives sooner is held and sent by the next flush, so the last state always goes
out. A client that subscribes gets the current state of that topic at once (WebSocket messages are not
latched), the static table included.
"""
from __future__ import annotations

import threading
import time
from collections import deque
from typing import Callable, Sequence

import foxglove
import numpy as np
from foxglove.channels import SceneUpdateChannel
from foxglove.messages import SceneUpdate
from foxglove.websocket import ServerListener

from foos_core.joints import joint_order, take_joints
from foos_core.names import JOINT_NAMES

from .scene import TableScene, stamp_text

TABLE_TOPIC = "/scene/table"
RODS_TOPIC = "/scene/rods"
BALL_TOPIC = "/scene/ball"
DETECTIONS_TOPIC = "/scene/detections"
SCENE_TOPICS = (TABLE_TOPIC, RODS_TOPIC, BALL_TOPIC, DETECTIONS_TOPIC)
# A detection stamped this much before the newest one means time restarted (a new sim run, a bag looped):
# the trail starts again instead of drawing a line back into the past.
TRAIL_RESTART_S = 1.0


class ViewerError(ValueError):
    """The viewer cannot start as asked (a port in use, a bad host or rate)."""


def _check_finite(topic: str, values: Sequence[float]) -> None:
    if not np.all(np.isfinite(values)):
        raise ValueError(f"{topic} holds a non-finite value: {tuple(values)}")


class _SubscribeListener(ServerListener):
    """Foxglove's server calls on_subscribe from its own thread; the topic is marked to be sent again."""

    def __init__(self, on_subscribe: Callable[[str], None]):
        self._on_subscribe = on_subscribe

    def on_subscribe(self, client, channel) -> None:
        self._on_subscribe(channel.topic)


class LiveScene:
    def __init__(self, scene: TableScene, host: str = "127.0.0.1", port: int = 8765, max_rate: float = 30.0,
                 trail_seconds: float = 0.5, name: str = "foos_viewer"):
        if not 0 <= port <= 65535:
            raise ViewerError(f"port must be in 0-65535 (0: any free port), got {port}")
        if not max_rate > 0:
            raise ViewerError(f"max_rate must be positive, got {max_rate}")
        if not trail_seconds >= 0:
            raise ViewerError(f"trail_seconds must be >= 0, got {trail_seconds}")
        self.scene = scene
        self.min_interval = 1.0 / max_rate
        self.trail_seconds = trail_seconds
        self._lock = threading.Lock()
        self._pending = set(SCENE_TOPICS)
        self._next_due = dict.fromkeys(SCENE_TOPICS, -float("inf"))
        self.sent = dict.fromkeys(SCENE_TOPICS, 0)
        self._joints = np.zeros(len(JOINT_NAMES))  # hanging, until /joint_states says otherwise
        self._joint_stamp = ""
        self._ball: tuple | None = None
        self._trail: deque = deque()  # (stamp seconds, stamp text, position)
        self._joint_orders: dict[tuple[str, ...], np.ndarray] = {}
        # A context of our own: channels and server belong together, and a second LiveScene in the same
        # process (a test) does not share the first one's topics.
        self._context = foxglove.Context()
        self._channels = {topic: SceneUpdateChannel(topic, context=self._context) for topic in SCENE_TOPICS}
        try:
            self.server = foxglove.start_server(name=name, host=host, port=port, context=self._context,
                                                server_listener=_SubscribeListener(self._mark))
        except RuntimeError as error:
            reason = str(error).removeprefix("FoxgloveError: ")
            hint = "; pick another with -p port:=N" if "in use" in reason else ""
            raise ViewerError(f"cannot serve Foxglove WebSocket on {host}:{port}: {reason}{hint}") from None
        self.host = host

    @property
    def port(self) -> int:
        return self.server.port

    @property
    def url(self) -> str:
        return f"ws://{'localhost' if self.host in ('127.0.0.1', '0.0.0.0', '::') else self.host}:{self.port}"

    def _mark(self, topic: str) -> None:
        with self._lock:
            self._pending.add(topic)

    # --- inputs ----------------------------------------------------------------------------------
    def set_joints(self, names: Sequence[str], positions: Sequence[float], stamp: tuple[int, int], now: float | None = None) -> None:
        """A /joint_states message; joints it does not name keep their last position (a table with some
        encoders), joints it names in any order are put in place by name."""
        if len(positions) != len(names):
            raise ValueError(f"/joint_states has {len(names)} names but {len(positions)} positions")
        key = tuple(names)
        if key not in self._joint_orders:  # a publisher keeps its names; look them up once
            self._joint_orders[key] = joint_order(key, allow_missing=True)
        order = self._joint_orders[key]
        # Merged at once: a table may publish its joints in several messages (one per drive) between flushes;
        # a joint it does not name, or a non-finite value, keeps the last position.
        received = take_joints(positions, order)
        self._joints = np.where(np.isfinite(received), received, self._joints)
        self._joint_stamp = stamp_text(*stamp)
        self._update(RODS_TOPIC, now)

    def set_ball(self, position: Sequence[float], velocity: Sequence[float], stamp: tuple[int, int], now: float | None = None) -> None:
        _check_finite("/ball/state", (*position, *velocity))
        self._ball = (tuple(position), tuple(velocity), stamp_text(*stamp))
        self._update(BALL_TOPIC, now)

    def add_detection(self, position: Sequence[float], stamp: tuple[int, int], now: float | None = None) -> None:
        _check_finite("/ball/detection", position)
        seconds = stamp[0] + stamp[1] * 1e-9
        if self._trail and seconds < self._trail[-1][0] - TRAIL_RESTART_S:
            self._trail.clear()
        self._trail.append((seconds, stamp_text(*stamp), tuple(position)))
        while self._trail[0][0] < self._trail[-1][0] - self.trail_seconds:
            self._trail.popleft()
        self._update(DETECTIONS_TOPIC, now)

    def _update(self, topic: str, now: float | None) -> None:
        self._mark(topic)
        self.flush(now)

    # --- outputs ---------------------------------------------------------------------------------
    def flush(self, now: float | None = None) -> None:
        """Send every held topic whose rate limit allows it now (and that a client subscribes to)."""
        now = time.monotonic() if now is None else now
        with self._lock:
            due = [t for t in self._pending if now >= self._next_due[t] and self._channels[t].has_sinks()]
            self._pending.difference_update(due)
        for topic in due:
            entities = self._entities(topic)
            if entities:  # nothing yet (no ball seen): nothing to send
                # Slots keep a steady cadence when updates come a little late (100 Hz input against 30 Hz
                # slots would otherwise give 25 Hz); after a pause the next slot is half an interval away.
                self._next_due[topic] = max(self._next_due[topic] + self.min_interval, now + self.min_interval / 2)
                self._channels[topic].log(SceneUpdate(entities=entities))
                self.sent[topic] += 1

    def _entities(self, topic: str) -> list:
        now_ns = time.time_ns()
        if topic == TABLE_TOPIC:
            return [self.scene.table_entity(now_ns)]
        if topic == RODS_TOPIC:
            return self.scene.rod_entities(self._joints, now_ns, self._joint_stamp)
        if topic == BALL_TOPIC:
            return [] if self._ball is None else [self.scene.ball_entity(*self._ball, now_ns)]
        trail = [position for _, _, position in self._trail]
        return [self.scene.detections_entity(trail, self._trail[-1][1] if self._trail else "", now_ns)] if trail else []

    def close(self) -> None:
        self.server.stop()
        for channel in self._channels.values():
            channel.close()
