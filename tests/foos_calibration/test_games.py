"""The game generator and calibrate on game bags, run the way a user runs them; bad game data refused."""
from __future__ import annotations

import json

import numpy as np

from foos_bag import (
    FLOAT64_MULTI_ARRAY,
    JOINT_STATE,
    BagWriter,
    read_commands,
    read_joint_states,
    topics,
    typestore,
    write_joint_states,
)
from foos_bag.message_types import header
from foos_calibration import games
from foos_core.names import JOINT_NAMES, TEAMS

from .test_calibration_cli import one_line_error


def test_a_game_bag_calibrates_its_rods(ros2_run, tmp_path):
    bag = tmp_path / "game"
    made = ros2_run("generate_measured", str(bag), "--game", "--duration", "30", "--seed", "2",
                    "--effect", "rod_latency:delay=0.04", timeout=120)
    assert made.returncode == 0, made.stderr
    names = topics(bag)
    assert {"/ball/detection", "/joint_states", "/home/rods/command", "/away/rods/command"} <= set(names)
    states = read_joint_states(bag)
    assert sorted(states.names) == sorted(JOINT_NAMES) and 200 <= 1 / np.median(np.diff(states.t)) <= 300
    assert all(read_commands(bag, team).values.shape[1] == 8 for team in TEAMS)
    out = tmp_path / "out"
    result = ros2_run("calibrate", str(bag), "--out", str(out), "--no-figures", "--max-starts", "10", timeout=300)
    assert result.returncode == 0, result.stderr
    report = json.loads((out / "report.json").read_text())
    rods = [e for e in report["effects"] if e["name"].startswith("rod_")]
    assert [e["name"] for e in rods] == ["rod_latency"] and abs(rods[0]["params"]["delay"] - 0.04) <= 0.005
    assert report["rods"]["calibrated"]["slide_median_error_mm_0_25s"] < report["rods"]["baseline"]["slide_median_error_mm_0_25s"]
    assert "rod_latency" in (out / "calibrated_table.yaml").read_text() and "## The rod drives" in (out / "report.md").read_text()


def write_game(path, t, names=JOINT_NAMES, commands=True, joints=True, backwards_at=None):
    """Zero joint states and commands; `backwards_at`: that joint state stamped 0.5 s before the one received before it."""
    store = typestore()
    with BagWriter(path) as writer:
        if joints and backwards_at is None:
            write_joint_states(writer, t, names, np.zeros((len(t), len(names))), np.zeros((len(t), len(names))))
        elif joints:
            writer.add_topic("/joint_states", JOINT_STATE)
            for i, ti in enumerate(t):
                msg = store.types[JOINT_STATE](header=header(ti - (0.5 if i == backwards_at else 0.0), ""), name=list(names),
                                               position=np.zeros(len(names)), velocity=np.zeros(len(names)), effort=np.zeros(0))
                writer.write("/joint_states", int(round(ti * 1e9)), msg)
        if commands:
            layout = store.types["std_msgs/msg/MultiArrayLayout"](dim=[], data_offset=0)
            for team in TEAMS:
                writer.add_topic(f"/{team}/rods/command", FLOAT64_MULTI_ARRAY)
                for ti in np.arange(0.0, 20.0, 0.02):
                    writer.write(f"/{team}/rods/command", int(ti * 1e9), store.types[FLOAT64_MULTI_ARRAY](layout=layout, data=np.zeros(8)))


def test_bad_game_data_is_refused_in_one_line_and_writes_nothing(ros2_run, tmp_path):
    t = np.arange(0.0, 20.0, 0.004)
    cases = {
        "no_joints": ({"joints": False}, "commands but no /joint_states"),
        "names": ({"names": [n.replace("home", "blue") for n in JOINT_NAMES]}, "not the contract's 16"),
    }
    for name, (kwargs, text) in cases.items():
        write_game(tmp_path / name, t, **kwargs)
        out = tmp_path / f"out_{name}"
        out.mkdir()
        (out / "report.json").write_text("kept")
        one_line_error(ros2_run("calibrate", str(tmp_path / name), "--out", str(out)), text)
        assert (out / "report.json").read_text() == "kept"
    # Encoder stamps going backwards: received in this order, stamped earlier.
    write_game(tmp_path / "backwards", t, backwards_at=100)
    one_line_error(ros2_run("calibrate", str(tmp_path / "backwards"), "--out", str(tmp_path / "o3")), "stamps go backwards")
    assert not (tmp_path / "o3").exists()


def test_a_figure_restitution_is_hidden_in_games_only(ros2_run, tmp_path):
    """`--game --effect figure_restitution:coefficient=C` plays the game on figures of that restitution (the same
    seed with dead and lively figures parts after the first figure touch); a free roll or a coefficient out of range
    is refused in one line."""
    def ball_path(coefficient: float) -> np.ndarray:
        effect = {"name": "figure_restitution", "params": {"coefficient": coefficient}}
        return games.play([effect], games.GameOptions(duration=4.0, seed=3, noise=0.0, dropout=0.0)).ball_position

    dead, lively = ball_path(0.2), ball_path(0.9)
    n = min(len(dead), len(lively))
    assert np.max(np.abs(dead[:n] - lively[:n])) > 0.01  # m: the bounces differ
    assert ros2_run("generate_measured", str(tmp_path / "game"), "--game", "--duration", "2",
                    "--effect", "figure_restitution:coefficient=0.3").returncode == 0
    for args, text in (((str(tmp_path / "free"),), "add --game"), ((str(tmp_path / "bad"), "--game", "--duration", "2"), "coefficient")):
        result = ros2_run("generate_measured", *args, "--effect", "figure_restitution:coefficient=1.5")
        lines = result.stderr.strip().splitlines()
        assert result.returncode == 2 and len(lines) == 1 and lines[0].startswith("generate_measured:") and text in lines[0], result.stderr
    assert not (tmp_path / "free").exists() and not (tmp_path / "bad").exists()
