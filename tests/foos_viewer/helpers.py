"""A Foxglove WebSocket client as the Foxglove app is one, and the viewer's processes as a user starts them.

The client speaks the SDK server's protocol (subprotocol `foxglove.sdk.v1`): the server sends serverInfo
and advertise (JSON), the client subscribes to channels by id, and each message comes as a binary
messageData frame: opcode 1, subscription id (uint32 LE), log time (uint64 LE, ns), then the payload,
here a protobuf message decoded with the schema the channel advertised (a FileDescriptorSet), not with
any class of ours.

ROS_DOMAIN_ID range of foos_viewer's tests: 100-101 (100: the DDS test, 101: bad-input runs).
"""
from __future__ import annotations

import base64
import json
import os
import re
import signal
import struct
import subprocess
import threading
import time
from contextlib import ExitStack

from google.protobuf import descriptor_pb2, descriptor_pool, message_factory
from websockets.sync.client import connect

from ..user_env import workspace_env

SUBPROTOCOL = "foxglove.sdk.v1"
MESSAGE_DATA = 1
PORT_IN_LOG = re.compile(r"Foxglove WebSocket on [^ ]+:(\d+)")


def message_class(schema_base64: str, name: str):
    return _message_class(base64.b64decode(schema_base64), name)


def _message_class(schema: bytes, name: str):
    files = descriptor_pb2.FileDescriptorSet.FromString(schema)
    pool = descriptor_pool.DescriptorPool()
    for file in files.file:
        pool.Add(file)
    return message_factory.GetMessageClass(pool.FindMessageTypeByName(name))


def decoded(message):
    """A foxglove.messages object as a client reads it: encoded, then decoded with its own schema."""
    schema = type(message).get_schema()
    return _message_class(schema.data, schema.name).FromString(message.encode())


class FoxgloveClient:
    """Connects, reads in a thread; `received` holds (monotonic arrival time, topic, decoded message)."""

    def __init__(self, url: str, timeout: float = 10.0):
        self._stack = ExitStack()
        self.socket = self._stack.enter_context(connect(url, subprotocols=[SUBPROTOCOL], open_timeout=timeout, max_size=None))
        self.server_info = json.loads(self.socket.recv(timeout=timeout))
        assert self.server_info["op"] == "serverInfo", self.server_info
        self.channels: dict[str, dict] = {}  # topic -> advertised channel
        self._classes: dict[int, object] = {}  # subscription id -> (topic, protobuf class)
        self.received: list[tuple[float, str, object]] = []
        self._lock = threading.Lock()
        self._closed = False
        self._thread = threading.Thread(target=self._read, daemon=True)
        self._thread.start()

    def _read(self) -> None:
        while not self._closed:
            try:
                frame = self.socket.recv(timeout=0.2)
            except TimeoutError:
                continue
            except Exception:  # the connection closed: reading is over
                return
            arrived = time.monotonic()
            if isinstance(frame, str):
                message = json.loads(frame)
                if message["op"] == "advertise":
                    with self._lock:
                        self.channels.update({channel["topic"]: channel for channel in message["channels"]})
                continue
            if frame[0] != MESSAGE_DATA:
                continue
            subscription, _log_time = struct.unpack_from("<IQ", frame, 1)
            topic, cls = self._classes[subscription]
            with self._lock:
                self.received.append((arrived, topic, cls.FromString(frame[13:])))

    def wait_for_channels(self, topics, timeout: float = 10.0) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            with self._lock:
                if all(topic in self.channels for topic in topics):
                    return
            time.sleep(0.02)
        raise AssertionError(f"the server did not advertise {topics}; it advertised {sorted(self.channels)}")

    def subscribe(self, topics) -> None:
        self.wait_for_channels(topics)
        subscriptions = []
        for topic in topics:
            channel = self.channels[topic]
            assert (channel["encoding"], channel["schemaEncoding"]) == ("protobuf", "protobuf"), channel
            subscription = len(self._classes) + 1
            self._classes[subscription] = (topic, message_class(channel["schema"], channel["schemaName"]))
            subscriptions.append({"id": subscription, "channelId": channel["id"]})
        self.socket.send(json.dumps({"op": "subscribe", "subscriptions": subscriptions}))

    def messages(self, topic: str, since: float = -float("inf")) -> list:
        with self._lock:
            return [(t, m) for t, tp, m in self.received if tp == topic and t >= since]

    def wait_for(self, topic: str, count: int = 1, timeout: float = 10.0, since: float = -float("inf")) -> list:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            got = self.messages(topic, since)
            if len(got) >= count:
                return got
            time.sleep(0.01)
        raise AssertionError(f"{len(self.messages(topic, since))} of {count} updates on {topic} within {timeout} s")

    def close(self) -> None:
        self._closed = True
        self._stack.close()
        self._thread.join(timeout=5)


def entities(update, prefix: str = "") -> dict:
    """A SceneUpdate's entities by id (those whose id starts with prefix)."""
    return {entity.id: entity for entity in update.entities if entity.id.startswith(prefix)}


def metadata(entity) -> dict[str, str]:
    return {pair.key: pair.value for pair in entity.metadata}


def xyz(message) -> tuple[float, float, float]:
    return (message.x, message.y, message.z)


class NodeProcess:
    """`ros2 run PACKAGE EXECUTABLE --ros-args -p ...` in the user's environment, its output read in a thread."""

    def __init__(self, domain: int, package: str, executable: str, *params: str):
        args = ["ros2", "run", package, executable]
        if params:
            args += ["--ros-args"] + [item for p in params for item in ("-p", p)]
        self.process = subprocess.Popen(args, env=workspace_env(domain), stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                        text=True, start_new_session=True)
        self.lines: list[str] = []
        self._reader = threading.Thread(target=self._read, daemon=True)
        self._reader.start()

    def _read(self) -> None:
        for line in self.process.stdout:
            self.lines.append(line.rstrip("\n"))

    def wait_for_line(self, pattern: re.Pattern, timeout: float = 30.0) -> re.Match:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            for line in list(self.lines):
                match = pattern.search(line)
                if match:
                    return match
            if self.process.poll() is not None:
                break
            time.sleep(0.05)
        raise AssertionError(f"no line matching {pattern.pattern}; output:\n" + "\n".join(self.lines))

    def stop(self) -> int:
        """Ctrl-C, then SIGKILL if it does not end in 10 s; its exit code."""
        if self.process.poll() is None:
            os.killpg(self.process.pid, signal.SIGINT)  # the group: `ros2 run` and the node it started
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                os.killpg(self.process.pid, signal.SIGKILL)
                self.process.wait()
        self._reader.join(timeout=5)
        return self.process.returncode
