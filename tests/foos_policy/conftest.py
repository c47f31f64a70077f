"""Shared fixtures of the policy tests: the workspace environment for subprocesses (helpers the tests
import are in helpers.py)."""
from __future__ import annotations

import subprocess

import pytest

from ..user_env import workspace_env


@pytest.fixture(scope="session")
def ros_env() -> dict:
    """The environment a user gets from `source scripts/env.sh`."""
    return workspace_env()


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
