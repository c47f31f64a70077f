"""Helpers for the bag tests: the user's environment (scripts/env.sh), processes started as a user starts
them (`ros2 bag ...`, `ros2 run ...`), and waiting on their logs. Every DDS test passes its own
ROS_DOMAIN_ID from this area's range, 20-39."""
from __future__ import annotations

import json
import re
import signal
import subprocess
import time
from pathlib import Path

import pytest

from ..user_env import workspace_env

ROOT = Path(__file__).resolve().parents[2]
BAGS = ROOT / "bags"


class Proc:
    """A user-level command in the background, its output in a log file."""

    def __init__(self, args: list[str], log: Path, domain: int, cwd: Path) -> None:
        env = workspace_env()
        env["ROS_DOMAIN_ID"] = str(domain)
        self.log = log
        self._file = open(log, "wb")
        self.popen = subprocess.Popen(args, stdout=self._file, stderr=subprocess.STDOUT, env=env, cwd=cwd)
        self.pid = self.popen.pid

    def text(self) -> str:
        return self.log.read_text(errors="replace")

    def wait_for(self, pattern: str, timeout: float, count: int = 1) -> None:
        end = time.monotonic() + timeout
        while time.monotonic() < end:
            if len(re.findall(pattern, self.text())) >= count:
                return
            if self.popen.poll() is not None:
                raise AssertionError(f"process exited (rc {self.popen.returncode}) before {pattern!r}:\n{self.text()}")
            time.sleep(0.05)
        raise AssertionError(f"timed out waiting for {pattern!r} ({count}x):\n{self.text()}")

    def signal(self, sig: int) -> None:
        if self.popen.poll() is None:
            self.popen.send_signal(sig)

    def wait(self, timeout: float) -> int:
        try:
            return self.popen.wait(timeout)
        except subprocess.TimeoutExpired:
            raise AssertionError(f"process did not exit within {timeout} s:\n{self.text()}") from None

    def stop(self) -> None:
        if self.popen.poll() is None:
            self.popen.send_signal(signal.SIGINT)
            try:
                self.popen.wait(5)
            except subprocess.TimeoutExpired:
                self.popen.kill()
                self.popen.wait(5)
        self._file.close()


@pytest.fixture
def launch(tmp_path):
    """launch(args, name, domain) -> Proc; every process is stopped (by its own pid) at teardown."""
    procs: list[Proc] = []

    def _launch(args: list[str], name: str, domain: int) -> Proc:
        assert 20 <= domain <= 39, "the bag tests own ROS_DOMAIN_IDs 20-39"
        proc = Proc(args, tmp_path / f"{name}.log", domain, tmp_path)
        procs.append(proc)
        return proc

    yield _launch
    for proc in reversed(procs):
        proc.stop()


def run_cli(args: list[str], cwd: Path, timeout: float = 60) -> subprocess.CompletedProcess:
    env = workspace_env()
    env["ROS_DOMAIN_ID"] = "39"  # offline commands; a domain of ours in case one touches DDS
    return subprocess.run(args, cwd=cwd, env=env, capture_output=True, text=True, timeout=timeout)


def load_log(path: Path) -> dict[str, list[int]]:
    with open(path) as f:
        return json.load(f)
