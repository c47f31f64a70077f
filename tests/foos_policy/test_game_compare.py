"""evaluate_bag's comparison of a recorded game with in-process ones (foos_policy.game.compare_games): Poisson rate
tests, widened by the in-process games' own spread where they spread more than Poisson counts."""
import pytest

from foos_policy.game import compare_games, dispersion, pool_games


def game(home, away, touches, seconds=300.0):
    return {"duration_s": seconds, "goals_home": home, "goals_away": away, "touches_home": touches, "touches_away": 0}


def test_dispersion_is_one_for_poisson_like_counts_and_grows_with_the_spread():
    assert dispersion([30], [300.0]) == 1.0
    assert dispersion([30, 31, 29, 30], [300.0] * 4) == 1.0  # less spread than Poisson: never below 1
    # the robot table's four 300 s in-process games of one policy (13-38 goals): about six times Poisson's spread
    assert dispersion([13, 38, 36, 19], [300.0] * 4) == pytest.approx(5.80, abs=0.01)


def reference(games):
    pooled = pool_games(games)
    pooled["per_game"] = games
    return pooled


def test_a_game_within_the_reference_games_spread_is_consistent_one_far_outside_is_not():
    games = [game(13, 7, 93), game(38, 35, 304), game(36, 28, 207), game(19, 16, 156)]
    bag = game(41, 31, 241)
    c = compare_games(bag, reference(games))
    assert c["consistent"] and c["poisson_p_values"]["home_touches"] < 0.01  # Poisson alone would call it different
    assert c["overdispersion"]["touches_home"] > 10
    far = compare_games(game(160, 31, 241), reference(games))
    assert not far["consistent"] and far["home_goals_p_value"] < 0.01


def test_without_per_game_data_the_poisson_tests_stand():
    pooled = pool_games([game(30, 20, 200), game(30, 20, 200)])
    c = compare_games(game(60, 20, 200), pooled)
    assert c["overdispersion"] == {"goals_home": 1.0, "goals_away": 1.0, "touches_home": 1.0}
    assert c["home_goals_p_value"] == c["poisson_p_values"]["home_goals"] < 0.01 and not c["consistent"]
