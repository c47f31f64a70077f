"""The user-facing commands, run as a user runs them: train, evaluate, evaluate_bag (offline bags)."""
from __future__ import annotations

import csv
import json

import numpy as np
import pytest

from foos_policy.metrics import CLOCK_COLUMNS, COLUMNS, SMOOTHED
from foos_policy.policies import algo_of

from .helpers import one_line_error


@pytest.fixture(scope="module")
def trained(tmp_path_factory, ros_env):
    """A tiny SAC run through the real CLI (the smoke test of the whole training pipeline): the default learner
    (SBX), the skill reward and the curriculum, whose three stages all come within 1000 steps."""
    import subprocess

    out = tmp_path_factory.mktemp("train")
    proc = subprocess.run(
        ["ros2", "run", "foos_policy", "train", "--algo", "sac", "--steps", "1000", "--learning-starts", "100",
         "--train-freq", "16", "--gradient-steps", "16", "--reward", "skill", "--curriculum",
         "--reset", "hardened", "--opponent", "scripted", "--seed", "3", "--out", str(out), "--checkpoint-every", "200"],
        capture_output=True, text=True, timeout=240, env=ros_env,
    )
    assert proc.returncode == 0, proc.stderr[-2000:]
    return out, proc


@pytest.mark.timeout(300)
def test_train_writes_model_metrics_figures_checkpoints_and_tensorboard(trained):
    out, proc = trained
    name = "sac_hardened_scripted_s3"
    assert (out / f"{name}.zip").is_file()
    with open(out / "metrics.csv") as f:
        rows = list(csv.DictReader(f))
    assert rows, "no finished episode in 1000 steps"
    assert tuple(rows[0]) == COLUMNS + CLOCK_COLUMNS
    # the curriculum's stages in order, ending on the task asked for
    stages = [r["stage"] for r in rows]
    assert stages[0] == "resting/none" and stages[-1] == "hardened/scripted", stages
    assert all(float(b["wall_s"]) >= float(a["wall_s"]) for a, b in zip(rows, rows[1:]))
    returns = np.array([float(r["return"]) for r in rows])
    # the paper's smoothing: Return50 is the running mean of the last (up to) 50 returns
    # (the CSV keeps 6 significant digits of each return and of their mean: where the returns nearly cancel, the
    # mean's own rounding is no guide, so the tolerance is the returns' rounding)
    assert float(rows[-1]["Return50"]) == pytest.approx(returns[-50:].mean(), abs=1e-5 * np.abs(returns[-50:]).max())
    assert {float(r["win"]) for r in rows} <= {0.0, 1.0}
    for png in ("return50", "eplen50", "winrate50", "loserate50", "termgoal50", "return_vs_length", "learning_curve"):
        assert (out / "figures" / f"{png}.png").stat().st_size > 1000
    assert list((out / "checkpoints").glob("*.zip"))
    assert list((out / "tb").rglob("events.out.tfevents.*"))
    run = json.loads((out / "run.json").read_text())
    assert 1000 <= run["steps_done"] < 1000 + 16 and run["algo"] == "sac"  # rollouts come in rounds of --train-freq
    assert (run["learner"], run["reward"], run["curriculum"]) == ("sbx", "skill", True)
    assert (run["params_file"], run["drive"]) == (None, "jerk_limited")  # the default table's drives, named
    assert algo_of(out / f"{name}.zip") == ("sbx", "sac")
    assert "it/s" in proc.stderr or "step" in proc.stderr  # the progress bar


@pytest.mark.timeout(300)
def test_evaluate_writes_a_summary_with_confidence_intervals(trained, run_cli, tmp_path):
    out, _ = trained
    for policy in (str(out / "sac_hardened_scripted_s3.zip"), "zero"):
        target = tmp_path / "eval.json"
        proc = run_cli("evaluate", "--policy", policy, "--reset", "hardened", "--opponent", "scripted",
                       "--episodes", "3", "--seed", "1", "--out", str(target), "--no-progress")
        assert proc.returncode == 0, proc.stderr
        summary = json.loads(target.read_text())
        for key in ("win_rate", "own_goal_rate", "mean_length", "touches", "goals_after_touch", "no_touch_goal_share"):
            assert key in summary
        lo, hi = summary["win_rate_ci95"]
        assert 0.0 <= lo <= summary["win_rate"] <= hi <= 1.0
        assert summary["episodes"] == 3


@pytest.mark.timeout(300)
def test_evaluate_transfer_pairs_the_same_episodes_on_other_tables(run_cli, tmp_path):
    """--transfer-to plays the very episodes of --params-file on other tables: on the same table again the paired
    change is exactly zero (same starts, same camera noise, deterministic physics); on another it is the
    difference of the two win rates, with a bootstrap interval around it."""
    from foos_core.table_params import ROBOT_PARAMS_FILE, SERVO_PARAMS_FILE

    target = tmp_path / "transfer.json"
    proc = run_cli("evaluate", "--policy", "scripted", "--reset", "hardened", "--opponent", "scripted", "--episodes", "6",
                   "--seed", "2", "--params-file", str(ROBOT_PARAMS_FILE),
                   "--transfer-to", str(ROBOT_PARAMS_FILE), str(SERVO_PARAMS_FILE), "--out", str(target), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(target.read_text())
    same, servo = summary["transfer"]
    assert same["win_difference"] == 0.0 and same["win_difference_ci95"] == [0.0, 0.0]
    assert same["own_goal_difference"] == 0.0 and same["win_rate"] == summary["win_rate"]
    assert servo["win_difference"] == pytest.approx(servo["win_rate"] - summary["win_rate"])
    lo, hi = servo["own_goal_difference_ci95"]
    assert lo <= servo["own_goal_difference"] <= hi
    assert "paired, same episodes" in proc.stdout and str(SERVO_PARAMS_FILE) in proc.stdout


@pytest.mark.timeout(300)
def test_evaluate_splits_the_own_goals_by_the_last_touch(run_cli, tmp_path):
    """Random actions on the robot table concede own goals off their own rods: every goal against is put down to
    the team that touched the ball last, and those off the home rods to the home rod nearest the touch."""
    from foos_core.table_params import ROBOT_PARAMS_FILE

    target = tmp_path / "random.json"
    proc = run_cli("evaluate", "--policy", "random", "--reset", "hardened", "--opponent", "scripted", "--episodes", "10",
                   "--seed", "7", "--params-file", str(ROBOT_PARAMS_FILE), "--out", str(target), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    summary = json.loads(target.read_text())
    by_touch, by_rod = summary["own_goals_by_last_touch"], summary["own_goals_by_home_rod"]
    assert summary["own_goal_rate"] > 0 and by_touch["home"] > 0
    assert sum(by_touch.values()) == pytest.approx(summary["own_goal_rate"])
    assert sum(by_rod.values()) == pytest.approx(by_touch["home"])
    assert set(by_rod) <= {"home_goalie", "home_defence", "home_midfield", "home_attack"}
    assert "own goals by the last touch: home" in proc.stdout
    # random actions whirl the rods: some of their touches are spins, and disallowing goals off spins cannot add wins
    assert 0 < summary["spun_touch_share"] <= 1 and summary["home_turns"] > 1
    assert summary["own_goals_off_spins"] <= by_touch["home"]
    assert summary["win_rate_without_spins"] == pytest.approx(summary["win_rate"] - summary["goals_off_spins"])
    assert "spins (a rod turned over 360 degrees" in proc.stdout


def test_paired_difference_resamples_whole_pairs():
    from foos_policy.evaluation import paired_difference

    base = np.array([1, 0, 1, 0, 1, 0, 1, 0] * 10)
    mean, lo, hi = paired_difference(base, base)
    assert (mean, lo, hi) == (0.0, 0.0, 0.0)  # independent intervals would each span about +-0.11
    flipped = base.copy()
    flipped[:8] = 1  # four more wins in 80 episodes
    mean, lo, hi = paired_difference(base, flipped)
    assert mean == pytest.approx(0.05) and 0.0 <= lo < 0.05 < hi <= 0.1
    with pytest.raises(ValueError, match="same episodes"):
        paired_difference(base, base[:-1])


@pytest.mark.timeout(180)
def test_self_play_against_a_frozen_policy(trained, run_cli, tmp_path):
    out, _ = trained
    frozen = str(out / "sac_hardened_scripted_s3.zip")
    proc = run_cli("evaluate", "--policy", frozen, "--reset", "hardened", "--opponent", "selfplay", "--opponent-policy", frozen,
                   "--episodes", "1", "--out", str(tmp_path / "selfplay.json"), "--no-progress")
    assert proc.returncode == 0, proc.stderr
    assert json.loads((tmp_path / "selfplay.json").read_text())["opponent"] == "selfplay"


@pytest.mark.timeout(300)
def test_the_torch_learner_still_trains_and_its_policy_plays(run_cli, tmp_path):
    """--learner sb3 (stable-baselines3 / sb3-contrib on torch, the paper's) beside the default SBX: a TQC zip that
    evaluate loads by its recorded class."""
    out = tmp_path / "sb3"
    proc = run_cli("train", "--learner", "sb3", "--algo", "tqc", "--steps", "150", "--learning-starts", "100",
                   "--train-freq", "1", "--gradient-steps", "1", "--reset", "hardened", "--opponent", "none",
                   "--out", str(out), "--no-progress")
    assert proc.returncode == 0, proc.stderr[-2000:]
    model = out / "tqc_hardened_none_s0.zip"
    assert algo_of(model) == ("sb3", "tqc")
    run = json.loads((out / "run.json").read_text())
    assert (run["learner"], run["train_freq"], run["gradient_steps"]) == ("sb3", 1, 1)
    proc = run_cli("evaluate", "--policy", str(model), "--reset", "hardened", "--opponent", "none", "--episodes", "1",
                   "--no-progress")
    assert proc.returncode == 0 and "1 episodes" in proc.stdout, proc.stderr


def test_metrics_smoothing_and_reader(tmp_path):
    from foos_policy.metrics import MetricsWriter, read_metrics

    w = MetricsWriter(tmp_path / "metrics.csv")
    for i in range(60):
        w.add(i * 10, {"return": float(i), "length": 10, "win": float(i % 2), "lose": 0.0, "term_goal": float(i % 2),
                       "touches": 1, "goal_after_touch": 0.0, "goal_without_touch": 0.0})
    w.close()
    m = read_metrics(tmp_path / "metrics.csv")
    assert m["Return50"][-1] == pytest.approx(np.arange(10, 60).mean())
    assert m["WinRate50"][-1] == pytest.approx(0.5)
    assert set(SMOOTHED) <= set(m)


@pytest.mark.timeout(120)
@pytest.mark.parametrize("exe", ["train", "evaluate", "evaluate_bag"])
def test_help_explains_the_command(run_cli, exe):
    proc = run_cli(exe, "--help")
    assert proc.returncode == 0
    assert "Example" in proc.stdout


@pytest.mark.timeout(180)
def test_bad_inputs_give_one_line_errors(run_cli, tmp_path):
    assert "does not exist" in one_line_error(run_cli("evaluate", "--policy", str(tmp_path / "missing.zip"), "--episodes", "1"))
    corrupt = tmp_path / "corrupt.zip"
    corrupt.write_bytes(b"not a zip at all")
    assert "not a saved SB3/SBX model" in one_line_error(run_cli("evaluate", "--policy", str(corrupt), "--episodes", "1"))
    assert "no policy named" in one_line_error(run_cli("evaluate", "--policy", "no_such_policy", "--episodes", "1"))
    assert "no bag" in one_line_error(run_cli("evaluate_bag", str(tmp_path / "nope")))
    # argparse refuses with its usage, then the error line
    refused = run_cli("train", "--reward", "paper", "--own-goal-penalty", "5", "--out", str(tmp_path / "t"))
    assert refused.returncode == 2 and "skill reward only" in refused.stderr.strip().splitlines()[-1]
    refused = run_cli("train", "--ent-coef", "-1", "--out", str(tmp_path / "t"))
    assert refused.returncode == 2 and "--ent-coef: must be at least 0" in refused.stderr.strip().splitlines()[-1]
    refused = run_cli("train", "--action-cost", "-1", "--out", str(tmp_path / "t"))
    assert refused.returncode == 2 and "--action-cost must be at least 0" in refused.stderr.strip().splitlines()[-1]
    not_a_bag = tmp_path / "empty_dir"
    not_a_bag.mkdir()
    one_line_error(run_cli("evaluate_bag", str(not_a_bag)))
    # a real bag without the topics evaluate_bag needs
    from foos_bag import BagWriter, write_ball_detections

    bag = tmp_path / "detections_only"
    with BagWriter(bag) as writer:
        write_ball_detections(writer, np.arange(5) * 0.01, np.zeros((5, 3)))
    assert "/ball/state" in one_line_error(run_cli("evaluate_bag", str(bag)))


@pytest.mark.timeout(300)
def test_evaluate_bag_on_a_written_game_matches_the_in_memory_analysis(run_cli, tmp_path):
    """An in-process game written to a real bag (foos_bag's writers) reads back to the same statistics."""
    from foos_bag import BagWriter, typestore, write_ball_states, write_joint_states
    from foos_core.names import JOINT_NAMES
    from foos_policy.game import analyze_game, play_game_samples
    from foos_policy.policies import make_policy

    s = play_game_samples(make_policy("scripted"), 12.0, seed=4)
    bag = tmp_path / "game"
    String = typestore().types["std_msgs/msg/String"]
    with BagWriter(bag) as writer:
        write_ball_states(writer, s["t"], s["ball_position"], s["ball_velocity"])
        write_joint_states(writer, s["t"], list(JOINT_NAMES), s["joint_positions"], s["joint_velocities"])
        writer.add_topic("/sim/goal", "std_msgs/msg/String")
        for t, team in zip(s["goal_times"], s["goals"]):
            writer.write("/sim/goal", int(t * 1e9), String(data=team))
    expected = analyze_game(s["params"], s["t"], s["ball_position"], s["ball_velocity"], s["t"], s["joint_positions"], s["goals"])
    proc = run_cli("evaluate_bag", str(bag), "--out", str(tmp_path / "stats.json"))
    assert proc.returncode == 0, proc.stderr
    got = json.loads((tmp_path / "stats.json").read_text())
    for key in ("goals_home", "goals_away", "touches_home", "touches_away", "shots_home"):
        assert got[key] == expected[key], key
    assert got["touches_home"] > 0
    assert got["possession_home"] == pytest.approx(expected["possession_home"], abs=1e-6)
