"""Position-target actions (foos_policy.actions): the braking-curve controller moves real simulated rods to their
targets on the robot table's jerk-limited drives without spinning them, for either team, and a model trained on
them plays through ModelPolicy as velocity actions. Corrections to the scripted controller (`residual`): zero tracks
and kicks as the scripted controller does, and the largest offsets hold the rods off their hold without spinning them."""
import numpy as np
import pytest

from foos_core.names import JOINT_NAMES, RODS
from foos_core.table_params import ROBOT_PARAMS_FILE, load_params
from foos_policy.actions import (
    LEAD_S,
    RESIDUAL_ACTION_HIGH,
    PositionTargets,
    ScriptedResidual,
    action_mode_of,
)
from foos_policy.env import FoosballEnv
from foos_policy.observation import ACTION_LIMIT, OWN_SLOT, action_to_command, observe, wrap_angle
from foos_sim.simulation import TableSimulation

ROBOT_TABLE = ROBOT_PARAMS_FILE


def test_a_models_action_box_names_its_mode():
    assert action_mode_of(np.full(8, 20.0)) == "velocity"
    assert action_mode_of(np.ones(8)) == "position"
    assert action_mode_of(np.tile([0.04, np.pi / 2], 4)) == "residual"
    with pytest.raises(ValueError, match="neither velocities"):
        action_mode_of(np.full(8, 5.0))


def drive_to(team: str, target_action, seconds: float, params_file=ROBOT_TABLE):
    """Both teams' rods under position targets (the other team's held), from the table's start; the trace of the
    team's joints in its own view, every 20 ms."""
    sim = TableSimulation(params_file)
    targets = PositionTargets(sim.params, sim.command_limits)
    sim.reset(ball_position=np.array([0.32, 0.0]), ball_velocity=np.zeros(2))
    trace = []
    for _ in range(round(seconds / 0.02)):
        obs = observe(team, sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())
        sim.set_command(team, action_to_command(team, targets.velocity_action(obs, target_action), sim.command_limits))
        sim.stop_team("away" if team == "home" else "home")
        sim.advance(0.02)
        obs = observe(team, sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())
        trace.append(obs[4:].reshape(8, 4))
    return np.array(trace), targets


@pytest.mark.parametrize("team", ["home", "away"])
def test_rods_reach_their_targets_without_overshoot_on_the_robot_drives(team):
    action = np.array([0.8, 0.5, -0.6, -0.5, 0.4, 0.9, -0.9, -0.95])  # slides, rotations up to 0.95 pi
    trace, targets = drive_to(team, action, 0.6)
    wanted = targets.targets(action)
    for r, rod in enumerate(RODS):
        slide, angle = trace[:, OWN_SLOT[rod], 0], trace[:, OWN_SLOT[rod], 2]
        assert slide[-1] == pytest.approx(wanted[2 * r], abs=0.003), rod
        assert angle[-1] == pytest.approx(wanted[2 * r + 1], abs=0.01), rod  # no limit cycle around it
        # from the start at 0, never further past the target than a centimetre or a quarter of a radian
        assert np.max(np.sign(wanted[2 * r]) * (slide - wanted[2 * r])) < 0.010, rod
        assert np.max(np.sign(wanted[2 * r + 1]) * (angle - wanted[2 * r + 1])) < 0.25, rod
        assert np.max(np.abs(trace[:, OWN_SLOT[rod], 3])) < 150.0, rod  # a half-turn, not a spin


def test_a_held_target_holds_the_rods_still():
    sim = TableSimulation(ROBOT_TABLE)
    targets = PositionTargets(sim.params, sim.command_limits)
    sim.reset(ball_position=np.array([0.32, 0.0]), ball_velocity=np.zeros(2))
    obs = observe("home", sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())
    assert np.all(targets.velocity_action(obs, np.zeros(8)) == 0.0)  # rods at their centres, hanging: nothing to do
    far = targets.velocity_action(obs, np.array([1.0, 1.0] * 4))
    assert np.all(far > 0) and np.all(far <= ACTION_LIMIT)


def test_the_env_takes_position_targets_and_a_trained_model_plays_them_as_velocities(tmp_path):
    from foos_policy.policies import algorithm_class, make_policy

    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_TABLE), action="position")
    assert env.action_space.high.max() == 1.0
    obs, _ = env.reset(seed=3)
    for _ in range(5):
        obs, *_ = env.step(np.full(8, 0.3, np.float32))
    rods = obs[4:].reshape(8, 4)
    assert rods[0, 0] > 0.0  # the own goalie slid toward its target
    SAC, _ = algorithm_class("sbx", "sac")
    model = SAC("MlpPolicy", env, seed=0, learning_starts=10, policy_kwargs=dict(net_arch=[8]))
    model.save(tmp_path / "position.zip")
    params = load_params(ROBOT_TABLE)
    policy = make_policy(str(tmp_path / "position.zip"), params, env.sim.command_limits)
    assert policy.action_mode == "position"
    target, _ = policy.model.predict(obs, deterministic=True)
    expected = PositionTargets(params, env.sim.command_limits).velocity_action(obs, target)
    assert np.array_equal(policy.predict(obs), expected)
    with pytest.raises(ValueError, match="action must be one of"):
        FoosballEnv(action="torque")


def test_joint_names_order_matches_the_command_layout():
    # PositionTargets reads (slide, rotate) per rod in RODS order, as the team command is laid out
    home = [n for n in JOINT_NAMES if n.startswith("home_")]
    assert home == [f"home_{rod}_{axis}" for rod in RODS for axis in ("slide", "rotate")]


def test_zero_corrections_track_and_kick_as_the_scripted_controller():
    """Along the scripted controller's own episodes: with no correction the slides get its very commands, and so
    does every rod it kicks with; the other rods are held hanging (on the braking curve, not its own hold)."""
    from foos_policy.policies import make_policy

    residual_env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_TABLE), action="residual")
    assert np.allclose(residual_env.action_space.high, RESIDUAL_ACTION_HIGH)
    env = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_TABLE))
    scripted = make_policy("scripted", env.sim.params, env.sim.command_limits)
    residual = ScriptedResidual(env.sim.params, env.sim.command_limits)
    kicks = 0
    for seed in (11, 12):
        obs, _ = env.reset(seed=seed)
        done = False
        while not done:
            expected, corrected = scripted.predict(obs), residual.velocity_action(obs, np.zeros(8))
            assert np.array_equal(corrected[0::2], expected[0::2])
            kicking = expected[1::2] == ACTION_LIMIT
            kicks += int(kicking.sum())
            assert np.array_equal(corrected[1::2][kicking], expected[1::2][kicking])
            rods = obs[4:].reshape(8, 4)[[OWN_SLOT[rod] for rod in RODS]]
            ahead = wrap_angle(rods[:, 2] + LEAD_S * rods[:, 3])  # where the figures are about to be
            turning_back = (np.abs(ahead) > 0.05) & ~kicking
            assert np.all(np.sign(corrected[1::2][turning_back]) == -np.sign(ahead[turning_back]))  # the short way
            obs, _, term, trunc, _ = env.step(expected)
            done = term or trunc
    assert kicks > 0


def test_the_largest_corrections_hold_the_rods_off_their_hold_without_spinning():
    """A constant offset moves each rod's hold by it (within the drives' settling) and turns no figure round: the
    same correction as a velocity (a fifth of the rotation limit) spun the rods round every 0.15 s."""
    sim = TableSimulation(ROBOT_TABLE)
    residual = ScriptedResidual(sim.params, sim.command_limits)
    # a still ball 0.195 m ahead of the home midfield and 0.105 m behind the home attack: no rod kicks it
    sim.reset(ball_position=np.array([0.0, 0.12]), ball_velocity=np.zeros(2))
    for sign in (1.0, -1.0):
        offset = sign * RESIDUAL_ACTION_HIGH
        angles = []
        for _ in range(50):  # 1 s
            obs = observe("home", sim.ball_position(), sim.ball_velocity(), sim.joint_positions(), sim.joint_velocities())
            sim.set_command("home", action_to_command("home", residual.velocity_action(obs, offset), sim.command_limits))
            sim.stop_team("away")
            sim.advance(0.02)
            rods = observe("home", sim.ball_position(), sim.ball_velocity(), sim.joint_positions(),
                           sim.joint_velocities())[4:].reshape(8, 4)[[OWN_SLOT[rod] for rod in RODS]]
            angles.append(rods[:, 2])
        angles = np.unwrap(np.array(angles), axis=0)
        assert np.all(np.abs(angles) < np.pi), angles.max(axis=0)  # never past a half turn either way
        assert angles[-1] == pytest.approx(np.full(4, sign * np.pi / 2), abs=0.35)


def test_the_action_cost_charges_the_mean_squared_share_of_the_bound():
    """Two envs on the same episode and the same corrections: the rewards differ by C x mean((a / bound)^2) a step."""
    plain = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_TABLE), action="residual", reward="skill")
    costly = FoosballEnv(reset="hardened", opponent="scripted", params_file=str(ROBOT_TABLE), action="residual", reward="skill",
                         action_cost=0.05)
    plain.reset(seed=4)
    costly.reset(seed=4)
    correction = np.float32([0.5, -1.0, 0.0, 0.25, 1.0, 0.0, -0.5, 0.5]) * RESIDUAL_ACTION_HIGH.astype(np.float32)
    for _ in range(5):
        _, reward, *_ = plain.step(correction)
        _, charged, *_ = costly.step(correction)
        assert reward - charged == pytest.approx(0.05 * np.mean(np.square([0.5, -1.0, 0.0, 0.25, 1.0, 0.0, -0.5, 0.5])))
    with pytest.raises(ValueError, match="action cost must be at least 0"):
        FoosballEnv(action_cost=-1.0)
