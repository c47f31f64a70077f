"""Kicks at the jerk-limited drives' speeds on both physics (issue 26): full kicks from back-swings of 45, 90 and
180 degrees, the fast physics against the 20 kHz reference, and random kicks and blocks with no tunnelling,
escape or NaN (1000 of them: `scripts/bench_sim --kicks 1000`)."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.table_params import ROBOT_PARAMS_FILE
from foos_sim.kick_trials import kick, random_trial
from foos_sim.simulation import TableSimulation

BACK_SWINGS = (45, 90, 180)
KICK_RODS = ("attack", "midfield", "goalie")
RANDOM_TRIALS = 40  # per physics here; scripts/bench_sim --kicks runs 1000


@pytest.fixture(scope="module")
def both():
    return {physics: TableSimulation(ROBOT_PARAMS_FILE, physics=physics) for physics in ("fast", "reference")}


@pytest.fixture(scope="module")
def kicks(both):
    """Every rod and back-swing kicked on both physics: {(rod, degrees): {physics: Kick}}."""
    return {(rod, degrees): {physics: kick(sim, degrees, rod) for physics, sim in both.items()}
            for rod in KICK_RODS for degrees in BACK_SWINGS}


@pytest.mark.parametrize("rod", KICK_RODS)
def test_a_kick_from_a_quarter_turn_sends_a_still_ball_off_at_a_players_shot_speed(kicks, rod):
    """From 90 degrees, the rod at rest: 6-15 m/s on both physics (real robots and players shoot 6-15 m/s)."""
    for physics, result in kicks[(rod, 90)].items():
        assert result is not None, physics
        assert 6.0 < result.ball_speed < 15.0, (physics, result)


@pytest.mark.parametrize("degrees", BACK_SWINGS)
@pytest.mark.parametrize("rod", KICK_RODS)
def test_the_fast_physics_kicks_as_the_reference_does(kicks, both, rod, degrees):
    """Within 5 % of the reference's ball speed, and never faster than (1 + e) times the foot at contact; a
    longer back-swing kicks harder."""
    result = kicks[(rod, degrees)]
    fast, reference = result["fast"], result["reference"]
    assert fast.ball_speed == pytest.approx(reference.ball_speed, rel=0.05)
    e = float(both["fast"].params["figures"]["restitution"])
    assert fast.ball_speed <= (1.0 + e) * fast.foot_speed
    if degrees > BACK_SWINGS[0]:
        shorter = kicks[(rod, BACK_SWINGS[BACK_SWINGS.index(degrees) - 1])]
        assert fast.ball_speed > shorter["fast"].ball_speed and reference.ball_speed > shorter["reference"].ball_speed


def test_a_ball_kicked_at_full_speed_is_never_faster_than_the_foot_allows(both):
    """A rod spinning at full speed (314 rad/s, its feet at 24 m/s) into a still ball: no faster than (1 + e)
    times its feet on either physics (a params file that only raised the old servo to 314 rad/s threw the
    ball at 130 m/s)."""
    speeds = {}
    for physics, sim in both.items():
        result = kick(sim, 0.0, "attack", run_up=0.3)  # at full speed from 0.19 s on
        assert result is not None and result.rod_speed > 300.0, physics
        e = float(sim.params["figures"]["restitution"])
        assert 20.0 < result.ball_speed <= (1.0 + e) * result.foot_speed, (physics, result)
        speeds[physics] = result.ball_speed
    assert speeds["fast"] == pytest.approx(speeds["reference"], rel=0.05)


@pytest.mark.parametrize("physics", ["fast", "reference"])
def test_random_kicks_and_blocks_neither_tunnel_nor_escape(both, physics):
    rng = np.random.default_rng(26)
    sim = both[physics]
    results = [random_trial(sim, rng) for _ in range(RANDOM_TRIALS)]
    bad = [(i, r) for i, r in enumerate(results) if not r.ok]
    assert not bad, bad
    assert max(r.max_ball_speed for r in results) > 8.0  # kicks at the new drives' speeds were among them


@pytest.mark.parametrize("ahead", [0.03, 0.05, 0.07])
def test_a_still_ball_before_a_still_figure_stays_put(ahead):
    """Nothing moves: the sweep test's closing speed is zero (it divided by it: a ZeroDivisionError whenever a rod held
    still at its target faced a ball at rest, as position-target policies and resting curricula do)."""
    sim = TableSimulation(ROBOT_PARAMS_FILE)
    y = float(sim.params["rods"]["layout"]["home_attack"]["y"]) + ahead
    sim.reset(ball_position=np.array([0.0, y]), ball_velocity=np.zeros(2))
    for team in ("home", "away"):
        sim.set_command(team, np.zeros(8))
    sim.advance(0.1)
    assert sim.ball_position()[:2] == pytest.approx((0.0, y), abs=1e-4)
    assert np.all(sim.joint_velocities() == 0.0)
