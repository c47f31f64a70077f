"""Decisions held over several control steps (foos_policy.decisions, `train --decision-period K`): the learner steps
once per K control steps with the summed reward, a saved model holds its actions alike in evaluate and policy_node,
and whatever turns the action into commands still acts on every step's newest observation."""
import numpy as np
import pytest

from foos_core.table_params import ROBOT_PARAMS_FILE
from foos_policy.actions import ScriptedResidual
from foos_policy.decisions import DecisionPeriod, HeldDecision
from foos_policy.env import FoosballEnv


def _env(**kwargs):
    return FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE), action="residual",
                       residual_base="lift-ahead", **kwargs)


def test_a_held_decision_is_due_on_the_first_step_and_every_period_after():
    decision = HeldDecision(3)
    assert [decision.due() for _ in range(7)] == [True, False, False, True, False, False, True]
    decision.reset()
    assert [decision.due() for _ in range(2)] == [True, False]
    assert [HeldDecision(1).due() for _ in range(3)] == [True, True, True]
    for bad in (0, -2, 2.5, True):
        with pytest.raises(ValueError, match="decision period"):
            HeldDecision(bad)


def test_one_learner_step_plays_the_action_for_the_period_and_sums_its_rewards():
    plain, held = _env(), DecisionPeriod(_env(), 4)
    plain.reset(seed=3)
    held.reset(seed=3)
    rng = np.random.default_rng(0)
    for _ in range(5):
        action = rng.uniform(-1, 1, 8).astype(np.float32) * plain.action_space.high
        rewards = []
        for _ in range(4):
            obs, reward, terminated, truncated, _ = plain.step(action)
            rewards.append(reward)
            if terminated or truncated:
                break
        held_obs, held_reward, held_terminated, held_truncated, _ = held.step(action)
        assert np.array_equal(obs, held_obs)
        assert held_reward == pytest.approx(sum(rewards), abs=1e-9)
        assert (held_terminated, held_truncated) == (terminated, truncated)
        if terminated or truncated:
            break
    assert held.control_steps == plain.stats.length == held.unwrapped.stats.length


def test_an_episode_end_ends_the_held_decision_early():
    held = DecisionPeriod(_env(), 10_000)          # longer than any episode
    held.reset(seed=4)
    _, _, terminated, truncated, info = held.step(np.zeros(8, np.float32))
    assert terminated or truncated
    assert "episode_stats" in info and info["episode_stats"]["length"] == held.control_steps < 10_000


def test_a_saved_model_holds_its_action_for_its_period_and_the_base_acts_every_step(tmp_path):
    from foos_policy.policies import algorithm_class, make_policy

    env = _env()
    SAC, _ = algorithm_class("sbx", "sac")
    model = SAC("MlpPolicy", env, seed=0, learning_starts=10, policy_kwargs=dict(net_arch=[8]))
    model.residual_base = "lift-ahead"
    model.decision_period = 3                      # as train --decision-period 3 saves it
    model.save(tmp_path / "held.zip")
    policy = make_policy(str(tmp_path / "held.zip"), env.sim.params, env.sim.command_limits)
    base = ScriptedResidual(env.sim.params, env.sim.command_limits, "lift-ahead")

    obs, _ = env.reset(seed=2)
    observations = [np.array(obs)]
    for _ in range(6):
        obs, *_ = env.step(np.zeros(8, np.float32))
        observations.append(np.array(obs))
    decided = [model.predict(o, deterministic=True)[0] for o in observations]
    assert not np.allclose(decided[0], decided[1])  # the net's choice moves with the ball: holding is visible

    policy.reset()
    actions = [policy.predict(o) for o in observations]
    for step, (o, action) in enumerate(zip(observations, actions)):
        held = decided[step - step % 3]            # decided on steps 0, 3 and 6, held in between
        assert np.array_equal(action, base.velocity_action(o, held)), step
    policy.reset()                                 # a new episode decides again at once
    assert np.array_equal(policy.predict(observations[1]), base.velocity_action(observations[1], decided[1]))


def test_train_refuses_a_period_under_one_step(tmp_path):
    from foos_policy.train import parse_args

    with pytest.raises(SystemExit):
        parse_args(["--decision-period", "0", "--out", str(tmp_path)])
    assert parse_args(["--decision-period", "5", "--out", str(tmp_path)]).decision_period == 5
