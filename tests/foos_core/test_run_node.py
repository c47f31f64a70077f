"""foos_core.nodes.run_node, the one main() of every node: bad input is one line and exit 2, Ctrl-C is exit 0
after on_exit ran while the context was still up."""
from __future__ import annotations

import os
import signal
import subprocess
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]
DOMAIN = "5"  # foos_core's ROS_DOMAIN_ID range is 1-9 (foos_sim 10-19, foos_bag 20-39, vision 40-59, policy 60-79,
# calibration 80-99, viewer 100-101)

NODE = """
import sys
import rclpy
from rclpy.node import Node
from foos_core.nodes import run_node

class Probe(Node):
    def __init__(self):
        super().__init__("probe")
        if "--bad" in sys.argv:
            raise ValueError("rate must be positive\\nsecond line")
        print("spinning", flush=True)

def last_words(node):
    print(f"on_exit ok={rclpy.ok()}", flush=True)

sys.exit(run_node("probe", Probe, on_exit=last_words))
"""


def run_probe(*args: str) -> subprocess.Popen:
    env = dict(os.environ, ROS_DOMAIN_ID=DOMAIN, PYTHONUNBUFFERED="1")
    return subprocess.Popen([sys.executable, "-c", NODE, *args], cwd=ROOT, env=env, text=True,
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)


def test_bad_input_is_one_line_and_exit_2():
    out, err = run_probe("--bad").communicate(timeout=60)
    assert err.strip() == "probe: error: rate must be positive"


def test_ctrl_c_runs_on_exit_with_the_context_up_and_exits_0():
    probe = run_probe()
    assert probe.stdout.readline().strip() == "spinning"
    time.sleep(0.2)
    probe.send_signal(signal.SIGINT)
    out, err = probe.communicate(timeout=30)
    assert probe.returncode == 0, err
    assert "on_exit ok=True" in out and "Traceback" not in err
