"""The lift-ahead base of the corrections (foos_policy.scripted, `train --residual-base lift-ahead`): the own rods
more than LIFT_MARGIN ahead of the ball hold their feet raised back and the ball passes under them; the rest play as
the scripted base does; a model saves the base it was trained on and plays on it."""
import numpy as np
import pytest

from foos_core.names import RODS
from foos_core.table_params import ROBOT_PARAMS_FILE, load_params
from foos_policy.actions import ScriptedResidual
from foos_policy.env import FoosballEnv
from foos_policy.observation import action_to_command, observe
from foos_policy.scripted import LIFT_AHEAD_ANGLE, LIFT_MARGIN, lift_ahead_angles, own_rod_geometry
from foos_sim.simulation import TableSimulation


def _rod_y(params) -> np.ndarray:
    geometry = own_rod_geometry(params)
    return np.array([geometry[rod].y for rod in RODS])


def test_only_the_rods_ahead_of_the_ball_by_the_margin_are_lifted():
    rod_y = _rod_y(load_params(ROBOT_PARAMS_FILE))  # goalie -0.525, defence -0.375, midfield -0.075, attack 0.225
    obs = np.zeros(36, np.float32)
    obs[1] = -0.2                                  # between the home defence and midfield
    assert np.array_equal(lift_ahead_angles(obs, rod_y), [0.0, 0.0, LIFT_AHEAD_ANGLE, LIFT_AHEAD_ANGLE])
    obs[1] = rod_y[3] - LIFT_MARGIN + 1e-3          # within the margin behind the attack: it still plays
    assert np.array_equal(lift_ahead_angles(obs, rod_y), [0.0, 0.0, 0.0, 0.0])
    obs[1] = -0.59                                 # behind the own goalie: every rod is ahead
    assert np.all(lift_ahead_angles(obs, rod_y) == LIFT_AHEAD_ANGLE)


def test_a_ball_ahead_of_every_rod_gets_the_scripted_base_and_one_behind_them_lifts_them():
    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE))
    scripted = ScriptedResidual(env.sim.params, env.sim.command_limits, "scripted")
    lifted = ScriptedResidual(env.sim.params, env.sim.command_limits, "lift-ahead")
    obs, _ = env.reset(seed=5)
    obs = np.array(obs)
    obs[1] = 0.5                                   # ahead of every own rod: nothing to lift
    assert np.array_equal(scripted.velocity_action(obs, np.zeros(8)), lifted.velocity_action(obs, np.zeros(8)))
    obs[1] = -0.45                                 # between the own goalie and defence
    differs = scripted.velocity_action(obs, np.zeros(8)) != lifted.velocity_action(obs, np.zeros(8))
    assert not differs[0::2].any()                 # the slides track as before
    assert np.array_equal(differs[1::2], [False, True, True, True])  # the three rods ahead turn to their lift
    with pytest.raises(ValueError, match="residual base must be one of"):
        ScriptedResidual(env.sim.params, env.sim.command_limits, "forward")


def test_a_ball_rolled_at_a_lifted_rod_passes_under_its_figures():
    """Real drives, real contacts: a ball rolled from behind the home midfield toward the away goal at 1.5 m/s
    passes the lifted midfield untouched (the hanging rod of the scripted base stops it: the check can fail)."""
    passed = {}
    for base in ("lift-ahead", "scripted"):
        sim = TableSimulation(ROBOT_PARAMS_FILE)
        residual = ScriptedResidual(sim.params, sim.command_limits, base)
        # x on a midfield figure (slide 0: figures at 0, +-0.12, +-0.24) and between the attack's (0, +-0.185)
        start = np.array([0.12, -0.2])
        sim.reset(ball_position=start, ball_velocity=np.zeros(2))
        for _ in range(25):                        # 0.5 s for the rods to settle on their hold, the ball at rest
            obs = observe("home", sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())
            obs[0] = 0.12                          # keep the slides where they are: the ball is placed after
            sim.set_command("home", action_to_command("home", residual.velocity_action(obs, np.zeros(8)), sim.command_limits))
            sim.stop_team("away")
            sim.advance(0.02)
        sim.place_ball(start, (0.0, 1.5))         # rolling toward the away goal
        furthest = start[1]
        for _ in range(10):                        # 0.2 s: past the midfield (0.125 m ahead) if unblocked
            sim.stop_team("home")
            sim.stop_team("away")
            sim.advance(0.02)
            furthest = max(furthest, float(sim.ball_position()[1]))
        passed[base] = furthest
    assert passed["lift-ahead"] > -0.075 + 0.05, passed    # past the midfield's axis (y = -0.075) and its feet
    assert passed["scripted"] < -0.075, passed


def test_a_model_saves_its_base_and_plays_on_it(tmp_path):
    from foos_policy.policies import algorithm_class, make_policy
    from foos_policy.train import parse_args

    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_PARAMS_FILE), action="residual",
                      residual_base="lift-ahead")
    SAC, _ = algorithm_class("sbx", "sac")
    model = SAC("MlpPolicy", env, seed=0, learning_starts=10, policy_kwargs=dict(net_arch=[8]))
    model.residual_base = "lift-ahead"             # as train saves it
    model.save(tmp_path / "lift.zip")
    policy = make_policy(str(tmp_path / "lift.zip"), env.sim.params, env.sim.command_limits)
    assert policy.residual_base == "lift-ahead"
    obs, _ = env.reset(seed=2)
    correction, _ = policy.model.predict(obs, deterministic=True)
    expected = ScriptedResidual(env.sim.params, env.sim.command_limits, "lift-ahead").velocity_action(obs, correction)
    assert np.array_equal(policy.predict(obs), expected)
    baseline = make_policy("lift-ahead", env.sim.params, env.sim.command_limits)
    assert np.array_equal(baseline.predict(obs), ScriptedResidual(env.sim.params, env.sim.command_limits,
                                                                  "lift-ahead").velocity_action(obs, np.zeros(8)))
    with pytest.raises(SystemExit):
        parse_args(["--residual-base", "lift-ahead", "--out", str(tmp_path)])  # only corrections have a base
