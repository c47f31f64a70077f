"""What a policy and its opponent see of the ball: a real table's camera loop (late, noisy) by default, the true
state at once on request (foos_policy.camera_view, FoosballEnv's view and opponent_view)."""
import numpy as np
import pytest

from foos_policy.camera_view import CameraView
from foos_policy.env import FoosballEnv


def test_the_camera_delivers_the_ball_of_latency_ago_between_records():
    view = CameraView(latency=0.03, position_noise=0.0, velocity_noise=0.0)
    rng = np.random.default_rng(0)
    for k in range(6):  # a ball rolling at 1 m/s along y, recorded every 20 ms
        t = 0.02 * k
        view.record(t, (0.0, t, 0.0175), (0.0, 1.0, 0.0), rng)
    position, velocity = view.ball()
    assert position[1] == pytest.approx(0.10 - 0.03)  # 30 ms ago, halfway between two records
    assert velocity[1] == pytest.approx(1.0)
    view.clear()
    view.record(5.0, (0.2, 0.3, 0.0175), (0.0, 0.0, 0.0), rng)
    assert view.ball()[0][:2] == pytest.approx((0.2, 0.3))  # a new episode's first frame shows its start


def test_the_camera_noise_has_the_configured_spread():
    view = CameraView(latency=0.0, position_noise=0.0015, velocity_noise=0.05)
    rng = np.random.default_rng(1)
    seen = []
    for k in range(4000):
        view.record(0.02 * k, (0.1, -0.2, 0.0175), (0.5, 0.0, 0.0), rng)
        seen.append(np.concatenate(view.ball()))
    seen = np.array(seen)
    assert np.std(seen[:, 0]) == pytest.approx(0.0015, rel=0.08) and np.mean(seen[:, 0]) == pytest.approx(0.1, abs=1e-4)
    assert np.std(seen[:, 3]) == pytest.approx(0.05, rel=0.08) and np.std(seen[:, 2]) < 1e-12  # height is not measured


@pytest.mark.parametrize("latency, noise", [(-0.01, 0.0), (0.04, float("nan"))])
def test_a_bad_camera_is_refused(latency, noise):
    with pytest.raises(ValueError, match="the camera's"):
        CameraView(latency=latency, position_noise=noise)


def test_both_teams_see_the_late_ball_by_default_and_the_truth_on_request():
    camera = FoosballEnv(reset="paper", opponent="none")
    instant = FoosballEnv(reset="paper", opponent="none", view="instant", opponent_view="instant")
    for env in (camera, instant):
        env.reset(seed=3)
        env.sim.place_ball((0.06, -0.32), (0.0, 1.0))  # rolling along y, clear of every figure for 0.1 s
        for _ in range(5):
            env.step(np.zeros(8))
    truth = camera.sim.ball_position()[:2]
    assert instant._observe("home")[:2] == pytest.approx(truth)
    assert instant._observe("away")[:2] == pytest.approx(-truth)
    seen = camera._observe("home")[:2]
    speed = np.hypot(*camera.sim.ball_velocity()[:2])
    assert speed > 0.8  # 40 ms late is centimetres off, far beyond the noise
    assert truth[1] - seen[1] == pytest.approx(0.04 * speed, abs=0.006)
    # one camera: the away team's view is the same measurement, mirrored
    assert camera._observe("away")[:2] == pytest.approx(-seen)
    with pytest.raises(ValueError, match="view must be one of"):
        FoosballEnv(view="oracle")
