"""Helpers the policy tests import."""
from __future__ import annotations

import subprocess

# This area's ROS_DOMAIN_ID range is 60-79; each DDS test takes its own.
DOMAIN_IDS = {"dds_game": 60, "policy_node_errors": 61, "policy_node_stale": 62, "policy_node_ctrl_c": 63}


def one_line_error(proc: subprocess.CompletedProcess) -> str:
    """The stderr of a failed command: one line, no traceback."""
    assert proc.returncode != 0, proc.stdout
    lines = [line for line in proc.stderr.strip().splitlines() if line.strip()]
    assert len(lines) == 1, proc.stderr
    assert "Traceback" not in proc.stderr
    return lines[0]
