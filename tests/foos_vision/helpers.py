"""Helpers of the vision tests: the user's environment (scripts/env.sh) and commands run the way a user
runs them (`ros2 run foos_vision ...`). DDS tests use ROS_DOMAIN_ID from this area's range, 40-59."""
from __future__ import annotations

import signal
import subprocess
from pathlib import Path

from ..user_env import workspace_env

ROOT = Path(__file__).resolve().parents[2]
# The simulated camera's command lives in foos_sim (rendering the table is the simulator's job).
SIM_COMMANDS = {"render_video"}


def ros2_run(executable: str, *args: str, timeout: float = 120, cwd: Path | None = None) -> subprocess.CompletedProcess:
    package = "foos_sim" if executable in SIM_COMMANDS else "foos_vision"
    return subprocess.run(["ros2", "run", package, executable, *args], capture_output=True, text=True,
                          env=workspace_env(), timeout=timeout, cwd=cwd or ROOT)


def render(out: Path, *args: str, timeout: float = 120) -> Path:
    """A rendered video (and its truth, camera and markers files) via `ros2 run foos_sim render_video`."""
    result = ros2_run("render_video", str(out), "--quiet", *args, timeout=timeout)
    assert result.returncode == 0, result.stderr
    return out


def stop_node(proc: subprocess.Popen) -> int:
    """Ctrl-C a node started with `ros2 run`; its exit code (a node that ignores SIGINT fails the test)."""
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            return proc.wait(10)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait(5)
            raise AssertionError("a node ignored SIGINT")
    return proc.returncode
