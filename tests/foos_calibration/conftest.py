"""Fixtures of the calibration tests: the workspace environment for `ros2 run` subprocesses."""
from __future__ import annotations

import subprocess

import pytest

from ..user_env import workspace_env

# This area's ROS_DOMAIN_ID range is 80-99 (no test here uses DDS yet).


@pytest.fixture(scope="session")
def ros_env() -> dict:
    """The environment a user gets from `source scripts/env.sh`."""
    return workspace_env(domain=80)


@pytest.fixture
def ros2_run(ros_env, tmp_path):
    """`ros2 run foos_calibration ARGS...` (or another package's command with `package=`)."""
    def run(*args: str, timeout: float = 240, package: str = "foos_calibration") -> subprocess.CompletedProcess:
        return subprocess.run(["ros2", "run", package, *args], capture_output=True, text=True,
                              timeout=timeout, env=ros_env, cwd=tmp_path)

    return run
