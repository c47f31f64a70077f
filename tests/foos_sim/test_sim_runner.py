"""sim_node's ROS-free core: schedule, camera model, watchdog, serves and goals."""
import math

import numpy as np
import pytest

from foos_core.names import JOINT_NAMES
from foos_sim.sim_runner import Detection, Goal, RunnerConfig, SimRunner, StateSample
from foos_sim.simulation import CommandError, TableSimulation


@pytest.fixture(scope="module")
def sim():
    return TableSimulation()


def run_for(runner, seconds):
    events = []
    end = runner.time + seconds
    while runner.time < end:
        events += runner.advance()
    return events


def test_samples_and_detections_come_at_their_rates_with_capture_stamps(sim):
    runner = SimRunner(sim, RunnerConfig(publish_rate=100, detection_rate=120, detection_latency=0.03, serve="random"))
    events = run_for(runner, 2.0)
    samples = [e for e in events if isinstance(e, StateSample)]
    detections = [e for e in events if isinstance(e, Detection)]
    assert len(samples) == pytest.approx(200, abs=2)
    assert len(detections) == pytest.approx(240 - 4, abs=6)  # the last 30 ms are still in flight
    np.testing.assert_allclose(np.diff([s.time for s in samples]), 0.01, atol=runner.sim.timestep)
    np.testing.assert_allclose(np.diff([d.capture_time for d in detections]), 1 / 120, atol=runner.sim.timestep)
    for d in detections:
        assert d.publish_time - d.capture_time == pytest.approx(0.03)


def test_detection_noise_and_dropout(sim):
    clean = SimRunner(sim, RunnerConfig(serve="none", initial_ball=(0.1, 0.2, 0.0, 0.0), seed=3))
    truth = [d.position for d in run_for(clean, 1.0) if isinstance(d, Detection)]
    noisy = SimRunner(sim, RunnerConfig(serve="none", initial_ball=(0.1, 0.2, 0.0, 0.0), seed=3,
                                        detection_noise=0.002, detection_dropout=0.2))
    seen = [d.position for d in run_for(noisy, 1.0) if isinstance(d, Detection)]
    assert 0.7 * len(truth) < len(seen) < 0.9 * len(truth)
    errors = np.array(seen)[:, :2] - np.array([0.1, 0.2])
    assert np.std(errors) == pytest.approx(0.002, rel=0.2)
    assert np.max(np.abs(np.array(truth)[:, :2] - [0.1, 0.2])) < 1e-4


def test_watchdog_stops_a_team_whose_commands_stop(sim):
    runner = SimRunner(sim, RunnerConfig(serve="none", command_timeout=0.2))
    command = np.zeros(8)
    command[5] = 10.0
    runner.command("home", command)
    run_for(runner, 0.1)
    rotate = JOINT_NAMES.index("home_midfield_rotate")
    assert runner.sim.joint_velocities()[rotate] == pytest.approx(10.0, rel=0.02)
    run_for(runner, 0.3)
    assert abs(runner.sim.joint_velocities()[rotate]) < 0.05


def test_bad_commands_are_refused(sim):
    runner = SimRunner(sim, RunnerConfig(serve="none"))
    with pytest.raises(CommandError, match="8 values"):
        runner.command("home", [0.0] * 7)
    with pytest.raises(CommandError, match="NaN"):
        runner.command("away", [0.0] * 7 + [math.nan])
    with pytest.raises(CommandError, match="NaN"):
        runner.command("away", [math.inf] + [0.0] * 7)
    with pytest.raises(CommandError, match="team"):
        runner.command("referee", [0.0] * 8)


def test_goal_is_reported_once_and_a_random_serve_follows(sim):
    runner = SimRunner(sim, RunnerConfig(serve="none", initial_ball=(0.0, 0.3, 0.0, 3.0)))
    # Lay the figures flat so the shot reaches the goal.
    runner.sim.data.qpos[[runner.sim.model.joint(n).qposadr[0] for n in JOINT_NAMES if n.endswith("rotate")]] = math.pi / 2
    goals = [e for e in run_for(runner, 1.0) if isinstance(e, Goal)]
    assert [g.team for g in goals] == ["home"]
    assert runner.score == {"home": 1, "away": 0}
    serving = SimRunner(sim, RunnerConfig(serve="random", seed=1))
    events = run_for(serving, 20.0)
    assert all(np.isfinite(e.ball_position).all() for e in events if isinstance(e, StateSample))
    speeds = [np.linalg.norm(e.ball_velocity[:2]) for e in events if isinstance(e, StateSample)]
    assert max(speeds) > 0.3, "random serves keep the ball rolling"


def test_bad_configuration_is_refused(sim):
    for bad in (RunnerConfig(publish_rate=0), RunnerConfig(detection_dropout=1.0), RunnerConfig(serve="kickoff"),
                RunnerConfig(detection_noise=-1), RunnerConfig(initial_ball=(math.nan, 0, 0, 0))):
        with pytest.raises(ValueError):
            SimRunner(sim, bad)
