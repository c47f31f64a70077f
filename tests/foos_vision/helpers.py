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


def spawn(domain: int, executable: str, *params: str, log) -> subprocess.Popen:
    """`ros2 run foos_vision EXECUTABLE --ros-args -p ...` in its own ROS_DOMAIN_ID, output to `log`."""
    args = ["ros2", "run", "foos_vision", executable, "--ros-args"]
    for p in params:
        args += ["-p", p]
    return subprocess.Popen(args, env=workspace_env(domain), stdout=log, stderr=subprocess.STDOUT)


def tracker_exit(domain: int, field_corners: str, video: Path, log_dir: Path, wait: float) -> tuple[int, str]:
    """tracker_node with `field_corners` fed `video` (looped) until the node ends: its exit code and its log."""
    log_path = log_dir / "tracker.log"
    with open(log_path, "wb") as log, open(log_dir / "source.log", "wb") as source_log:
        tracker = spawn(domain, "tracker_node", f"field_corners:={field_corners}", log=log)
        source = spawn(domain, "video_source", f"source:={video}", "wait_for_subscribers:=1", "loop:=true",
                       log=source_log)
        try:
            code = tracker.wait(wait)
        finally:
            stop_node(source)
            if tracker.poll() is None:
                stop_node(tracker)
    return code, log_path.read_text()
