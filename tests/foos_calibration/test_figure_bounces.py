"""figure_restitution from a game's ball-figure bounces (foos_calibration.figure_bounces), hidden by the table the
game is played on: the generating parameters' `figures: restitution`, which the fast physics' impact rule applies
(foos_sim.impacts; the model's own mechanism, no outside one)."""
from __future__ import annotations

import copy

import pytest

from foos_calibration import games
from foos_calibration.figure_bounces import find_figure_restitution
from foos_calibration.figure_contacts import FigureModel, JointTrack
from foos_calibration.figure_kinks import detection_noise, find_kinks
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import FAST_PARAMS_FILE, load_params

# The replays fit high at high restitution (0.88 for 0.75 hidden at seed 1, 0.53 for 0.5): the tolerance.
TOLERANCE = 0.15


@pytest.fixture(scope="module")
def nominal():
    return load_params(FAST_PARAMS_FILE)


def restitution_of_game(nominal: dict, hidden: float, seed: int):
    table = copy.deepcopy(nominal)
    table["figures"]["restitution"] = hidden
    game = games.play([], games.GameOptions(duration=90.0, seed=seed), params=table)
    t, xy = game.ball_t, game.ball_position[:, :2]
    noise = detection_noise(t, xy)
    kinks = find_kinks(t, xy, TableGeometry.from_params(nominal), noise)
    joints = JointTrack(game.joint_t, game.joint_position)
    return find_figure_restitution(kinks, t, xy, FigureModel(nominal), joints, nominal, noise)


def test_a_livelier_figure_is_found(nominal):
    found = restitution_of_game(nominal, 0.75, seed=1)
    assert found.coefficient is not None and abs(found.coefficient - 0.75) <= TOLERANCE, found.block
    assert [e["name"] for e in found.effects] == ["figure_restitution"] and found.block["clean_replays"] >= 8
    assert min(found.evidence["per_fold"]) > 0 and found.evidence["ci95"][0] > 0.5


def test_the_nominal_figures_name_nothing(nominal):
    found = restitution_of_game(nominal, 0.5, seed=1)
    assert found.coefficient is None and found.effects == [], found.block
    assert abs(found.fitted - 0.5) < 0.08
