"""Shared fixtures of the policy tests: the workspace environment for subprocesses (helpers the tests
import are in helpers.py)."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]


@pytest.fixture(scope="session")
def ros_env() -> dict:
    """The environment a user gets from `source scripts/env.sh` (read once from a bash that sources it)."""
    out = subprocess.run(
        ["bash", "-c", f"source {ROOT}/scripts/env.sh >/dev/null && env -0"],
        check=True, capture_output=True, cwd=ROOT,
    ).stdout
    env = dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONUNBUFFERED"] = "1"
    return env


@pytest.fixture
def run_cli(ros_env, tmp_path):
    """Run `ros2 run foos_policy EXE ARGS` the way a user does; returns the CompletedProcess."""

    def run(exe: str, *args: str, timeout: float = 120, domain: int | None = None) -> subprocess.CompletedProcess:
        env = dict(ros_env)
        if domain is not None:
            env["ROS_DOMAIN_ID"] = str(domain)
        return subprocess.run(["ros2", "run", "foos_policy", exe, *args], capture_output=True, text=True,
                              timeout=timeout, env=env, cwd=tmp_path)

    return run
