"""The gymnasium env: API checks, the paper's observation/action/reward, resets, terminations, touches."""
from __future__ import annotations

import numpy as np
import pytest

from foos_core.names import JOINT_NAMES
from foos_policy.curriculum import stage_at, stages
from foos_policy.env import FoosballEnv
from foos_policy.observation import OBS_SIZE, action_to_command, command_to_action, observe
from foos_policy.tasks import HardenedPlacement, PaperReward, PaperServe, SkillReward


@pytest.fixture(scope="module")
def env():
    return FoosballEnv("hardened", "scripted")


@pytest.mark.timeout(120)
def test_gymnasium_and_sb3_env_checkers_pass():
    from gymnasium.utils.env_checker import check_env
    from stable_baselines3.common.env_checker import check_env as sb3_check_env

    with pytest.warns(UserWarning):  # only the advice to normalise the paper's [-20, 20] box and infinite bounds
        check_env(FoosballEnv("paper", "none"), skip_render_check=True)
    with pytest.warns(UserWarning):
        sb3_check_env(FoosballEnv("hardened", "scripted"))


def test_spaces_are_the_papers(env):
    assert env.observation_space.shape == (36,)
    assert env.action_space.shape == (8,)
    assert env.action_space.low.min() == -20 and env.action_space.high.max() == 20
    assert env.dt == pytest.approx(0.02)  # 50 Hz control over the 20 kHz physics


def _mirrored(ball_p, ball_v, q, dq):
    """The same table state turned by 180 degrees about z: x, y flip, and the teams swap rods with
    negated slide and rotation."""
    n = len(q) // 2
    swap = np.r_[np.arange(n, 2 * n), np.arange(n)]
    return -ball_p, -ball_v, -q[swap], -dq[swap]


def test_away_view_is_the_home_view_of_the_mirrored_table():
    rng = np.random.default_rng(3)
    p, v = rng.normal(size=3) * 0.2, rng.normal(size=3)
    q, dq = rng.normal(size=16) * 0.5, rng.normal(size=16)
    home = observe("home", p, v, q, dq)
    away = observe("away", *_mirrored(p, v, q, dq))
    np.testing.assert_allclose(home, away, atol=1e-6)
    assert home.shape == (OBS_SIZE,)
    # slot 0 is the home goalie, slot 7 the away goalie
    assert home[4] == pytest.approx(q[JOINT_NAMES.index("home_goalie_slide")])
    assert home[4 + 7 * 4] == pytest.approx(q[JOINT_NAMES.index("away_goalie_slide")])


def test_actions_map_linearly_onto_the_drive_limits_and_mirror_for_away(env):
    limits = env.sim.command_limits
    full = np.full(8, 20.0)
    np.testing.assert_allclose(action_to_command("home", full, limits), limits)
    np.testing.assert_allclose(action_to_command("away", full, limits), -limits)
    np.testing.assert_allclose(action_to_command("home", np.full(8, 99.0), limits), limits)  # clipped to the box
    a = np.linspace(-20, 20, 8)
    np.testing.assert_allclose(command_to_action("away", action_to_command("away", a, limits), limits), a)


def test_reward_is_the_papers_formula():
    r = PaperReward()
    half = 0.6
    y_v = 0.8 * half
    base = r(0.0, 0.1, None, np.zeros(8), half)
    assert base == pytest.approx(50 * 0.1 + 5 / (1 + abs(y_v - 0.1)))
    assert r(0.1, 0.0, None, np.zeros(8), half) == pytest.approx(5 / (1 + y_v))  # no reward for going back
    assert r(0.0, 0.1, "home", np.zeros(8), half) - base == pytest.approx(1000)
    assert r(0.0, 0.1, "away", np.zeros(8), half) - base == pytest.approx(-1000)
    assert base - r(0.0, 0.1, None, np.full(8, 20.0), half) == pytest.approx(1e-4 * 8 * 400)


def test_resets_draw_the_documented_distributions(env):
    rng = np.random.default_rng(0)
    serves = [PaperServe().sample(rng, env.sim) for _ in range(300)]
    p = np.array([s[0] for s in serves])
    v = np.array([s[1] for s in serves])
    assert np.all(np.abs(p[:, 0]) <= 0.005) and np.all(p[:, 1] == 0)
    assert v[:, 1].min() >= 0 and v[:, 1].max() <= 15 and v[:, 1].max() > 13
    assert np.all(np.abs(v[:, 0]) <= 0.5)
    placed = [HardenedPlacement().sample(rng, env.sim) for _ in range(300)]
    p = np.array([s[0] for s in placed])
    speed = np.hypot(*np.array([s[1] for s in placed]).T)
    assert np.all(np.abs(p[:, 1]) < 0.35) and np.all(speed <= 0.2)
    # unaided, the fastest ball rolls v^2 / (2 * 0.15) = 0.13 m: far from either goal line at 0.6
    assert np.all(np.abs(p[:, 1]) + speed**2 / 0.3 < 0.5)


@pytest.mark.timeout(120)
def test_hardened_reset_needs_a_touch_to_score():
    env = FoosballEnv("hardened", "none")
    wins = 0
    for seed in range(5):
        env.reset(seed=seed)
        while True:
            _, _, terminated, truncated, info = env.step(np.zeros(8))
            if terminated or truncated:
                break
        stats = info["episode_stats"]
        assert stats["stagnant"] == 1.0 and stats["touches"] == 0
        wins += stats["win"]
    assert wins == 0


@pytest.mark.timeout(60)
def test_a_served_ball_into_the_goal_ends_the_episode_as_a_win_without_touch():
    env = FoosballEnv("paper", "none")
    env.reset(seed=0)
    # a ball rolling through the gap beside the away goalie (at x = 0) into the away goal
    env.sim.reset(ball_position=(0.06, 0.45), ball_velocity=(0.0, 3.0))
    for _ in range(20):
        _, reward, terminated, truncated, info = env.step(np.zeros(8))
        if terminated:
            break
    stats = info["episode_stats"]
    assert stats["win"] == 1.0 and stats["term_goal"] == 1.0
    assert stats["goal_without_touch"] == 1.0 and stats["goal_after_touch"] == 0.0
    assert reward > 1000


@pytest.mark.timeout(60)
def test_a_kick_is_counted_as_a_home_touch_and_moves_the_ball_forward():
    env = FoosballEnv("paper", "none")
    env.reset(seed=0)
    # ball still, 5 cm in front of the home attack's middle figure (x = 0, rod at y = 0.225)
    env.sim.reset(ball_position=(0.0, 0.275), ball_velocity=(0.0, 0.0))
    kick = np.zeros(8)
    kick[7] = 20.0  # attack rotate, full speed toward +y
    vy = []
    for _ in range(3):
        obs, *_ = env.step(kick)
        vy.append(obs[3])
    assert env.stats.touches_home >= 1
    assert max(vy) > 0.5  # ball vy after the kick, m/s (before it meets the away rods)


@pytest.mark.timeout(60)
def test_vectorised_training_env_steps():
    from stable_baselines3.common.vec_env import DummyVecEnv

    vec = DummyVecEnv([lambda: FoosballEnv("hardened", "scripted") for _ in range(2)])
    vec.seed(0)
    obs = vec.reset()
    assert obs.shape == (2, 36)
    for _ in range(5):
        obs, rewards, dones, infos = vec.step(np.zeros((2, 8), np.float32))
    assert rewards.shape == (2,) and np.all(np.isfinite(rewards))


def test_lifted_opponent_starts_with_every_away_rod_horizontal():
    env = FoosballEnv("paper", "lifted")
    env.reset(seed=0)
    q = env.sim.joint_positions()
    for i, name in enumerate(JOINT_NAMES):
        expected = -np.pi / 2 if name.startswith("away_") and name.endswith("_rotate") else 0.0
        assert q[i] == pytest.approx(expected), name


def test_skill_reward_is_potential_based_progress_plus_touch_and_goals():
    r = SkillReward()
    half = 0.6
    # the progress term is signed: a ball sent forward and back again earns nothing net
    path = [0.0, 0.1, 0.25, 0.05, -0.1]
    total = sum(r(a, b, None, np.zeros(8), half) for a, b in zip(path, path[1:]))
    assert total == pytest.approx(5.0 * (path[-1] - path[0]))
    assert r(0.0, 0.0, None, np.zeros(8), half, first_touch=True) == pytest.approx(0.5)
    assert r(0.0, 0.0, "home", np.zeros(8), half) == pytest.approx(10.0)
    assert r(0.0, 0.0, "away", np.zeros(8), half) == pytest.approx(-10.0)
    # no control cost: the paper's is 0.03 at full action, noise next to these returns
    assert r(0.0, 0.1, None, np.full(8, 20.0), half) == r(0.0, 0.1, None, np.zeros(8), half)


def test_an_own_goal_penalty_changes_only_the_conceded_goal():
    from foos_policy.tasks import make_reward

    r = make_reward("skill", own_goal_penalty=25.0)
    half = 0.6
    assert r(0.0, 0.0, "away", np.zeros(8), half) == pytest.approx(-25.0)
    assert r(0.0, 0.0, "home", np.zeros(8), half) == pytest.approx(10.0)
    assert r(0.0, 0.1, None, np.zeros(8), half) == pytest.approx(0.5)
    env = FoosballEnv("hardened", "scripted", reward="skill", own_goal_penalty=25.0)
    assert env.reward_fn.own_goal_penalty == 25.0
    with pytest.raises(ValueError, match="skill reward only"):
        make_reward("paper", own_goal_penalty=25.0)
    with pytest.raises(ValueError, match="at least 0"):
        make_reward("skill", own_goal_penalty=-1.0)



def test_the_spin_penalty_puts_the_skill_reward_under_the_tournament_rule():
    """A spun home touch costs the penalty and a goal off one pays nothing; without a penalty spins are free."""
    from foos_policy.tasks import make_reward

    free, ruled = make_reward("skill"), make_reward("skill", spin_penalty=2.0)
    assert free(0.0, 0.0, None, np.zeros(8), 0.6, spun_touches=3) == 0.0
    assert ruled(0.0, 0.0, None, np.zeros(8), 0.6, spun_touches=3) == -6.0
    assert free(0.0, 0.0, "home", np.zeros(8), 0.6, goal_spun=True) == 10.0
    assert ruled(0.0, 0.0, "home", np.zeros(8), 0.6, goal_spun=True) == 0.0
    assert ruled(0.0, 0.0, "home", np.zeros(8), 0.6, goal_spun=False) == 10.0
    with pytest.raises(ValueError, match="skill reward only"):
        make_reward("paper", spin_penalty=1.0)
    with pytest.raises(ValueError, match="at least 0"):
        make_reward("skill", spin_penalty=-1.0)

def test_the_skill_env_pays_the_first_touch_once():
    env = FoosballEnv("paper", "none", reward="skill")
    env.reset(seed=0)
    env.sim.reset(ball_position=(0.0, 0.275), ball_velocity=(0.0, 0.0))
    kick = np.zeros(8)
    kick[7] = 20.0
    rewards, ys = [], [0.275]
    for _ in range(4):
        obs, reward, *_ = env.step(kick)
        rewards.append(reward)
        ys.append(float(env.sim.ball_position()[1]))
    assert env.stats.touches_home >= 1
    bonus = [reward - 5.0 * (b - a) for reward, a, b in zip(rewards, ys, ys[1:])]
    assert sorted(np.round(bonus, 6)) == [0.0, 0.0, 0.0, 0.5], bonus


def test_a_curriculum_ends_on_the_task_and_set_task_changes_the_next_episode():
    plain = stages("hardened", "scripted", enabled=False)
    assert [(s.reset, s.opponent) for s in plain] == [("hardened", "scripted")]
    course = stages("hardened", "scripted", enabled=True)
    assert [(s.reset, s.opponent) for s in course] == [("resting", "none"), ("hardened", "none"), ("hardened", "scripted")]
    assert stage_at(course, 0.0).reset == "resting" and stage_at(course, 0.2).opponent == "none"
    assert stage_at(course, 0.5) == stage_at(course, 1.5) == course[-1]

    env = FoosballEnv("hardened", "scripted")
    env.set_task("resting", "none")
    env.reset(seed=3)
    assert np.linalg.norm(env.sim.ball_velocity()[:2]) == 0.0 and env.stats.task == "resting/none"
    assert env.opponent.act(np.zeros(36)) is None  # the away rods stand still
    env.set_task("hardened", "scripted")
    env.reset(seed=3)
    assert env.stats.task == "hardened/scripted" and env.opponent.act(env._observe("away")) is not None


def test_a_late_opponent_acts_on_what_it_saw_steps_ago_and_forgets_at_reset():
    """--opponent-delay 0.06 s: at every step the scripted away team decides on the away observation of 3
    control steps earlier (the episode's first one until then), and a new episode forgets the last one."""
    late = FoosballEnv("hardened", "scripted", opponent_delay=0.06)
    assert late.opponent_delay_steps == 3
    scripted = late.opponent.opponent
    decided_on = []
    original_act = scripted.act
    scripted.act = lambda obs: decided_on.append(np.array(obs)) or original_act(obs)
    for episode in range(2):
        late.reset(seed=episode)
        decided_on.clear()
        seen = []
        rng = np.random.default_rng(episode)
        for _ in range(8):
            seen.append(late._observe("away"))
            late.step(rng.uniform(-20, 20, 8))
        for step, obs in enumerate(decided_on):
            np.testing.assert_array_equal(obs, seen[max(0, step - 3)])
    assert FoosballEnv("hardened", "scripted").opponent_delay_steps == 0
    with pytest.raises(ValueError, match="at least 0 s"):
        FoosballEnv("hardened", "scripted", opponent_delay=-0.02)
