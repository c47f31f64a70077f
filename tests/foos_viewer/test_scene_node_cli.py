"""scene_node's bad inputs, run as a user runs it: one line on stderr and exit 2 (ROS_DOMAIN_ID 101)."""
import socket
import subprocess

import pytest

from ..user_env import workspace_env

DOMAIN = 101


def run_scene_node(*params: str) -> subprocess.CompletedProcess:
    args = ["ros2", "run", "foos_viewer", "scene_node", "--ros-args"] + [item for p in params for item in ("-p", p)]
    return subprocess.run(args, env=workspace_env(DOMAIN), capture_output=True, text=True, timeout=60)


@pytest.mark.timeout(120)
def test_a_port_in_use_is_one_line_and_exit_2():
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        port = taken.getsockname()[1]
        result = run_scene_node(f"port:={port}")
    assert result.returncode == 2, result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1, result.stderr
    assert lines[0].startswith(f"scene_node: error: cannot serve Foxglove WebSocket on 127.0.0.1:{port}: ")
    assert "in use" in lines[0] and "-p port:=N" in lines[0]


@pytest.mark.timeout(120)
@pytest.mark.parametrize("params, message", [
    (("params_file:=/nonexistent/table.yaml",), "scene_node: error: parameter file not found: /nonexistent/table.yaml"),
    (("port:=70000",), "scene_node: error: port must be in 0-65535 (0: any free port), got 70000"),
    (("port:=0", "max_rate:=0.0"), "scene_node: error: max_rate must be positive, got 0.0"),
    (("port:=8765.5",), "scene_node: error: port must be a whole number, got 8765.5"),
    (("port:=0", "trail_seconds:=soon"), "scene_node: error: trail_seconds must be a number, got 'soon'"),
])
def test_bad_parameters_are_one_line_and_exit_2(params, message):
    result = run_scene_node(*params)
    assert result.returncode == 2, result.stderr
    assert result.stderr.strip().splitlines() == [message]
