"""Over DDS: sim_node + policy_node play on sim time, the recorder captures it, evaluate_bag agrees with
the in-process game of the same policy. Real processes started with `ros2 run`, as a user does."""
from __future__ import annotations

import json
import signal
import subprocess
import time

import numpy as np
import pytest

from foos_policy.policies import shipped_policies

from .helpers import DOMAIN_IDS, one_line_error

# Every test here starts nodes that talk over DDS.
pytestmark = pytest.mark.dds

GAME_WALL_S = 25.0


def _policy_under_test() -> str:
    shipped = shipped_policies()
    return "sac_hardened_scripted_s0" if "sac_hardened_scripted_s0" in shipped else "scripted"


def _start(env, tmp_path, name, *cmd):
    log = open(tmp_path / f"{name}.log", "w")
    return subprocess.Popen(list(cmd), stdout=log, stderr=subprocess.STDOUT, env=env, cwd=tmp_path, start_new_session=True)


def _stop(proc, timeout=15.0) -> int:
    if proc.poll() is None:
        proc.send_signal(signal.SIGINT)
        try:
            return proc.wait(timeout)
        except subprocess.TimeoutExpired:
            proc.kill()
            proc.wait()
            return -9
    return proc.returncode


def _wait_for_log(proc, log, text: str, timeout: float) -> None:
    """Until the running process has logged text, or timeout seconds have passed."""
    deadline = time.time() + timeout
    while time.time() < deadline and text not in log.read_text():
        assert proc.poll() is None, log.read_text()
        time.sleep(0.5)


@pytest.mark.timeout(240)
def test_sim_node_and_policy_node_game_recorded_and_evaluated(ros_env, tmp_path):
    env = dict(ros_env, ROS_DOMAIN_ID=str(DOMAIN_IDS["dds_game"]))
    policy = _policy_under_test()
    bag = tmp_path / "game"
    procs = {}
    try:
        procs["recorder"] = _start(env, tmp_path, "recorder", "ros2", "bag", "record", "-o", str(bag), "--use-sim-time",
                                   "/ball/state", "/joint_states", "/sim/goal", "/home/rods/command", "/away/rods/command")
        procs["home"] = _start(env, tmp_path, "home", "ros2", "run", "foos_policy", "policy_node", "--ros-args",
                               "-p", f"policy:={policy}", "-p", "team:=home", "-p", "use_sim_time:=true",
                               "-p", "latency_period:=2.0")
        # the away team: a second node, mirrored, that holds its rods (zero policy) - the game stays the
        # in-process one (no away commands = stopped drives) while the away topic and mirroring are exercised
        procs["away"] = _start(env, tmp_path, "away", "ros2", "run", "foos_policy", "policy_node", "--ros-args",
                               "-p", "policy:=zero", "-p", "team:=away", "-p", "use_sim_time:=true")
        time.sleep(4.0)  # nodes up and discovered before the game starts
        procs["sim"] = _start(env, tmp_path, "sim", "ros2", "run", "foos_sim", "sim_node", "--ros-args",
                              "-p", "serve:=random", "-p", "seed:=0", "-p", "publish_clock:=true", "-p", "real_time_factor:=1.0")
        time.sleep(GAME_WALL_S)
        for name in ("sim", "home", "away"):
            assert procs[name].poll() is None, (tmp_path / f"{name}.log").read_text()[-2000:]
    finally:
        codes = {name: _stop(procs[name]) for name in ("recorder", "home", "away", "sim") if name in procs}
    assert codes["home"] == 0 and codes["away"] == 0 and codes["recorder"] == 0, codes
    home_log = (tmp_path / "home.log").read_text()
    assert "inference latency" in home_log

    from foos_bag import read_commands, topics

    counts = {topic: count for topic, (_, count) in topics(bag).items()}
    assert counts["/ball/state"] > 500, counts
    assert counts["/home/rods/command"] > 200 and counts["/away/rods/command"] > 200, counts
    away = read_commands(bag, "away")
    assert abs(away.values).max() == 0.0

    out = tmp_path / "stats.json"
    proc = subprocess.run(["ros2", "run", "foos_policy", "evaluate_bag", str(bag), "--out", str(out),
                           "--compare-policy", policy, "--seed", "0"],
                          capture_output=True, text=True, timeout=180, env=env, cwd=tmp_path)
    assert proc.returncode == 0, proc.stderr
    stats = json.loads(out.read_text())
    assert stats["duration_s"] > 5.0
    assert stats["touches_home"] > 0 and stats["in_process"]["touches_home"] > 0
    assert stats["comparison"]["consistent"], stats["comparison"]


@pytest.mark.timeout(60)
def test_policy_node_without_inputs_holds_the_rods_warns_and_stops_cleanly(ros_env, tmp_path):
    env = dict(ros_env, ROS_DOMAIN_ID=str(DOMAIN_IDS["policy_node_stale"]))
    node = _start(env, tmp_path, "lonely", "ros2", "run", "foos_policy", "policy_node", "--ros-args", "-p", "policy:=random")
    try:
        log = tmp_path / "lonely.log"
        _wait_for_log(node, log, "holding the rods", 30)
    finally:
        code = _stop(node)
    text = log.read_text()
    assert "holding the rods: no /joint_states received yet" in text
    assert code == 0 and "Traceback" not in text


@pytest.mark.timeout(120)
def test_policy_node_stopped_with_ctrl_c_sends_a_last_zero_command(ros_env, tmp_path):
    """Ctrl-C stops the drives at once: the last command on the topic is all zeros, and the exit is clean.
    (With rclpy's own handler the context was already shut down when the zero command was due.)"""
    env = dict(ros_env, ROS_DOMAIN_ID=str(DOMAIN_IDS["policy_node_ctrl_c"]))
    bag = tmp_path / "commands"
    procs = {}
    try:
        procs["recorder"] = _start(env, tmp_path, "recorder", "ros2", "bag", "record", "-o", str(bag), "/home/rods/command")
        # on sim time, so that a sim slowed down by a loaded machine does not make the inputs stale
        procs["sim"] = _start(env, tmp_path, "sim", "ros2", "run", "foos_sim", "sim_node", "--ros-args", "-p", "serve:=random",
                              "-p", "publish_clock:=true")
        procs["home"] = _start(env, tmp_path, "home", "ros2", "run", "foos_policy", "policy_node", "--ros-args",
                               "-p", "policy:=random", "-p", "team:=home", "-p", "use_sim_time:=true")
        _wait_for_log(procs["home"], tmp_path / "home.log", "inference latency", 60)
        home_code = _stop(procs.pop("home"))
        time.sleep(1.0)  # the recorder takes the last command before it stops
    finally:
        codes = {name: _stop(proc) for name, proc in procs.items()}
    log = (tmp_path / "home.log").read_text()
    assert home_code == 0 and "Traceback" not in log, log[-2000:]
    assert codes["recorder"] == 0, codes

    from foos_bag import read_commands

    commands = read_commands(bag, "home").values
    moving = np.abs(commands).max(axis=1) > 0
    assert len(commands) > 50 and moving.sum() > 10, (len(commands), moving.sum(), log[-1500:])
    assert abs(commands[-1]).max() == 0.0, commands[-5:]


@pytest.mark.timeout(60)
def test_policy_node_refuses_a_bad_policy_or_team(run_cli):
    line = one_line_error(run_cli("policy_node", "--ros-args", "-p", "policy:=no_such_policy",
                                  domain=DOMAIN_IDS["policy_node_errors"], timeout=45))
    assert "no policy named" in line
    line = one_line_error(run_cli("policy_node", "--ros-args", "-p", "policy:=zero", "-p", "team:=referee",
                                  domain=DOMAIN_IDS["policy_node_errors"], timeout=45))
    assert "team" in line
