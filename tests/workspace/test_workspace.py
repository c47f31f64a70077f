"""The workspace as a new user meets it: set-up, the sourced shell, and the ros2 stand-in."""
import os
import subprocess
from pathlib import Path

ROOT = Path(__file__).resolve().parents[2]


def bash(script: str, env=None) -> subprocess.CompletedProcess:
    return subprocess.run(["bash", "-c", script], cwd=ROOT, capture_output=True, text=True, env=env, timeout=600)


def test_setup_is_idempotent():
    result = bash("./scripts/setup")
    assert result.returncode == 0, result.stderr
    assert ".venv up to date" in result.stdout and "ros2_ws up to date" in result.stdout


def test_sourced_shell_offers_the_packages_and_their_executables():
    result = bash("source scripts/env.sh && ros2 pkg executables foos_sim && python -c 'import foos_sim; print(foos_sim.load_model().nu)'")
    assert result.returncode == 0, result.stderr
    assert "foos_sim sim_node" in result.stdout
    assert result.stdout.strip().endswith("16")


def test_ros2_run_errors_are_one_clear_line():
    missing_pkg = bash("source scripts/env.sh && ros2 run no_such_pkg node")
    assert missing_pkg.returncode != 0 and "Package 'no_such_pkg' not found" in missing_pkg.stderr
    missing_exe = bash("source scripts/env.sh && ros2 run foos_sim no_such_node")
    assert missing_exe.returncode != 0
    assert "No executable 'no_such_node'" in missing_exe.stderr and "sim_node" in missing_exe.stderr


def test_a_real_ros2_on_path_wins_over_the_stand_in(tmp_path):
    fake = tmp_path / "bin"
    fake.mkdir()
    (fake / "ros2").write_text("#!/bin/sh\necho real-ros2\n")
    (fake / "ros2").chmod(0o755)
    env = dict(os.environ, PATH=f"{fake}:{os.environ['PATH'].replace(str(ROOT / '.venv/standin/bin'), '')}")
    result = bash("source scripts/env.sh && ros2", env=env)
    assert result.stdout.strip() == "real-ros2"


def test_env_sh_is_safe_under_set_u():
    result = bash("set -u; source scripts/env.sh; echo ok; [[ $- == *u* ]] && echo still-u")
    assert result.returncode == 0, result.stderr
    assert "ok" in result.stdout and "still-u" in result.stdout
