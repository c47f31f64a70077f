"""Fixtures of the calibration tests: the workspace environment for `ros2 run` subprocesses."""
from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# This area's ROS_DOMAIN_ID range is 80-99 (no test here uses DDS yet).


@pytest.fixture(scope="session")
def ros_env() -> dict:
    """The environment a user gets from `source scripts/env.sh`."""
    out = subprocess.run(["bash", "-c", f"source {ROOT}/scripts/env.sh >/dev/null && env -0"],
                         check=True, capture_output=True, cwd=ROOT).stdout
    env = dict(item.split("=", 1) for item in out.decode().split("\0") if "=" in item)
    env["OMP_NUM_THREADS"] = "1"
    env["PYTHONUNBUFFERED"] = "1"
    env["ROS_DOMAIN_ID"] = "80"
    return env


@pytest.fixture
def ros2_run(ros_env, tmp_path):
    def run(*args: str, timeout: float = 240) -> subprocess.CompletedProcess:
        return subprocess.run(["ros2", "run", "foos_sim", *args], capture_output=True, text=True,
                              timeout=timeout, env=ros_env, cwd=tmp_path)

    return run
