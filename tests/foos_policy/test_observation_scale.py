"""The learner's scaled view of the observation (`train --observation scaled`): sizes of about 1 whatever the
drives, the saved model's observation box says which view it was trained on, and a model trained on the scaled view
is fed it by ModelPolicy (so evaluate and policy_node play it as trained), while the env keeps the raw observation."""
import numpy as np
import pytest

from foos_core.table_params import ROBOT_PARAMS_FILE, load_params
from foos_policy.env import FoosballEnv
from foos_policy.observation import OBS_SCALE, OBS_SCALED_BOUND, observes_scaled, scaled_observation
from foos_policy.train import ScaledObservation


def test_the_scaled_view_brings_a_spinning_rod_to_the_size_of_a_ball_position():
    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE))
    obs, _ = env.reset(seed=1)
    for _ in range(25):  # full-speed rotation commands: the rods spin at up to 314 rad/s
        obs, *_ = env.step(np.tile([0.0, 20.0], 4).astype(np.float32))
    assert np.abs(obs).max() > 50.0
    view = scaled_observation(obs)
    spins = np.abs(view[7::4])  # each rod's rotation velocity
    assert 0.5 < spins.max() < OBS_SCALED_BOUND  # of order 1, not clipped
    assert np.abs(view[:2]).max() < 1.0  # ball positions stay below 1 after scaling (0.6 m scale)
    assert scaled_observation(np.full(36, 1e6)).max() == OBS_SCALED_BOUND


def test_a_models_observation_box_names_its_view():
    env = FoosballEnv()
    assert not observes_scaled(env.observation_space)
    assert observes_scaled(ScaledObservation(env).observation_space)
    env.observation_space = type(env.observation_space)(-3.0, 3.0, (36,), np.float32)
    with pytest.raises(ValueError, match="neither raw"):
        observes_scaled(env.observation_space)


def test_a_model_trained_on_the_scaled_view_is_fed_it_and_the_env_keeps_the_raw_one(tmp_path):
    from foos_policy.policies import PolicyError, algorithm_class, make_policy

    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE), action="residual")
    wrapped = ScaledObservation(env)
    view, _ = wrapped.reset(seed=4)
    assert np.array_equal(view, scaled_observation(env._home_obs))  # the env's own observation stays raw
    SAC, _ = algorithm_class("sbx", "sac")
    model = SAC("MlpPolicy", wrapped, seed=0, learning_starts=10, policy_kwargs=dict(net_arch=[8]))
    model.save(tmp_path / "unrecorded.zip")  # the scales not saved with it: refused, as any other scales would be
    with pytest.raises(PolicyError, match="scaled observation with scales None"):
        make_policy(str(tmp_path / "unrecorded.zip"), load_params(ROBOT_PARAMS_FILE), env.sim.command_limits)
    model.observation_scale = OBS_SCALE.tolist()  # as train saves it
    model.save(tmp_path / "scaled.zip")
    policy = make_policy(str(tmp_path / "scaled.zip"), load_params(ROBOT_PARAMS_FILE), env.sim.command_limits)
    assert policy.observes_scaled and policy.action_mode == "residual"
    raw = env._home_obs
    correction, _ = policy.model.predict(scaled_observation(raw), deterministic=True)
    assert np.array_equal(policy.predict(raw), policy.action_map.velocity_action(raw, correction))
    unscaled, _ = policy.model.predict(raw, deterministic=True)
    assert not np.allclose(unscaled, correction)  # so feeding the raw view would be a different policy
