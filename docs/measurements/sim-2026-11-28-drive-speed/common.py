"""Shared by this log's scripts: the repository root, the parameter files and bench_sim's game (imported from the
script itself, so the games are the bench's). Run with the workspace environment sourced (scripts/env.sh); put a
foos_sim source folder first on PYTHONPATH to measure another version of it."""
from __future__ import annotations

import importlib.machinery
import importlib.util
import os
from pathlib import Path

ROOT = Path(os.environ.get("FOOS_ROOT", Path(__file__).resolve().parents[3]))
PARAMS = ROOT / "ros2_ws/src/foos_core/foos_core/params"
ROBOT, SERVO = str(PARAMS / "robot_table.yaml"), str(PARAMS / "servo_table.yaml")


def bench_sim():
    """scripts/bench_sim as a module (its game(), raw_cost(), api_cost())."""
    os.environ["FOOS_BENCH_SIM_READY"] = "1"  # already in the environment: no re-exec
    loader = importlib.machinery.SourceFileLoader("bench_sim", str(ROOT / "scripts/bench_sim"))
    spec = importlib.util.spec_from_loader("bench_sim", loader)
    module = importlib.util.module_from_spec(spec)
    loader.exec_module(module)
    return module
