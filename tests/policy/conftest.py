"""Shared fixtures of the policy tests: the workspace environment for subprocesses, and DDS domains."""
from __future__ import annotations

import os
import subprocess
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
# This area's ROS_DOMAIN_ID range is 60-79; each DDS test takes its own.
DOMAIN_IDS = {"dds_game": 60, "policy_node_errors": 61, "policy_node_stale": 62}


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


def one_line_error(proc: subprocess.CompletedProcess) -> str:
    """The stderr of a failed command: one line, no traceback."""
    assert proc.returncode != 0, proc.stdout
    lines = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]
