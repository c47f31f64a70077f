"""policy_node's ROS-free core: joint mapping by name, stale inputs, mirroring, latency."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import JOINT_NAMES
from foos_policy.controller import PolicyController, StateError, ball_sample, joint_sample
from foos_policy.policies import make_policy
from foos_sim.simulation import TableSimulation


@pytest.fixture(scope="module")
def sim():
    return TableSimulation()


def test_joint_states_are_mapped_by_name():
    names = list(reversed(JOINT_NAMES))
    q = np.arange(16.0)
    sample = joint_sample(1.0, names, q, -q)
    assert sample.positions[0] == 15.0 and sample.velocities[0] == -15.0
    assert joint_sample(1.0, names, q, []).velocities.sum() == 0.0  # velocities are optional in JointState
    with pytest.raises(StateError, match="lacks"):
        joint_sample(1.0, names[:-1], q[:-1], q[:-1])
    with pytest.raises(StateError, match="NaN"):
        joint_sample(1.0, names, np.r_[np.nan, q[1:]], q)
    with pytest.raises(StateError, match="NaN"):
        ball_sample(1.0, (np.inf, 0, 0), (0, 0, 0))


def _steps_after_states(controller, joints_at: float, ball_at: float, acts_at: float, holds_at: float):
    """The controller fed still joints and a still ball stamped at the given times, stepped twice."""
    controller.joints = joint_sample(joints_at, JOINT_NAMES, np.zeros(16), np.zeros(16))
    controller.ball = ball_sample(ball_at, (0, 0, 0.0175), (0, 0, 0))
    return controller.step(acts_at), controller.step(holds_at)


def test_stale_or_missing_inputs_hold_the_rods(sim):
    c = PolicyController(make_policy("random"), "home", sim.command_limits, stale_after=0.1)
    command, reason = c.step(0.0)
    assert "no /joint_states" in reason and not command.any()
    (command, reason), (held, why) = _steps_after_states(c, 1.0, 1.0, 1.05, 1.5)
    assert reason is None and command.any()
    assert "/joint_states is 0.50 s old" in why and not held.any()
    stats = c.latency_stats()
    assert stats["n"] == 1 and stats["median_ms"] >= 0


def test_a_camera_loops_late_ball_state_still_drives_the_rods(sim):
    """By default a /ball/state 0.12 s old (a 30 fps frame plus 80 ms of detection) is used, not held on."""
    c = PolicyController(make_policy("random"), "home", sim.command_limits)
    (command, reason), (held, why) = _steps_after_states(c, 1.0, 0.88, 1.0, 1.2)
    assert reason is None and command.any()
    assert "/ball/state is 0.32 s old" in why and not held.any()


def test_the_away_team_plays_the_mirrored_game(sim):
    """Scripted home on a state and scripted away on the table turned by 180 degrees give opposite commands."""
    rng = np.random.default_rng(1)
    home = PolicyController(make_policy("scripted", sim.params, sim.command_limits), "home", sim.command_limits)
    away = PolicyController(make_policy("scripted", sim.params, sim.command_limits), "away", sim.command_limits)
    for _ in range(20):
        p = np.r_[rng.uniform(-0.3, 0.3), rng.uniform(-0.5, 0.5), 0.0175]
        v = np.r_[rng.normal(size=2), 0.0]
        q, dq = rng.normal(size=16) * 0.05, rng.normal(size=16)
        swap = np.r_[np.arange(8, 16), np.arange(8)]
        home.joints, home.ball = joint_sample(0, JOINT_NAMES, q, dq), ball_sample(0, p, v)
        away.joints, away.ball = joint_sample(0, JOINT_NAMES, -q[swap], -dq[swap]), ball_sample(0, -p, -v)
        np.testing.assert_allclose(home.step(0.0)[0], -away.step(0.0)[0], atol=1e-5)


def test_wilson_interval_holds_the_rate_at_the_edges():
    from foos_policy.evaluation import wilson_interval

    assert wilson_interval(0, 60)[0] == 0.0 and wilson_interval(60, 60)[1] == 1.0
    lo, hi = wilson_interval(13, 100)
    assert lo == pytest.approx(0.078, abs=1e-3) and hi == pytest.approx(0.210, abs=1e-3)
