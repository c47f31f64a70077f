"""The simulated camera in sim_node's loop, without ROS: frames at the camera's rate instead of detections,
each the pose of its own time, filmed with the ball where the camera model projects it."""
import math

import numpy as np
import pytest

from foos_core.camera_model import CameraConfigError
from foos_sim.camera.errors import RenderError
from foos_sim.camera.live import LiveCamera, LiveCameraConfig, ros_distortion_model
from foos_sim.sim_runner import CameraFrame, Detection, RunnerConfig, SimRunner, StateSample
from foos_sim.simulation import TableSimulation


def test_a_camera_rate_gives_frames_of_their_own_time_and_no_detections():
    sim = TableSimulation()
    runner = SimRunner(sim, RunnerConfig(publish_rate=100, camera_rate=60, serve="none",
                                         initial_ball=(0.05, -0.2, 0.4, 0.8)))
    events, poses = [], {}
    end = runner.time + 1.0
    while runner.time < end:
        for event in runner.advance():
            events.append(event)
            if isinstance(event, CameraFrame):
                poses[event.capture_time] = sim.ball_position()
    frames = [e for e in events if isinstance(e, CameraFrame)]
    assert not [e for e in events if isinstance(e, Detection)]
    assert len(frames) == pytest.approx(60, abs=1)
    assert len([e for e in events if isinstance(e, StateSample)]) == pytest.approx(100, abs=1)
    np.testing.assert_allclose(np.diff([f.capture_time for f in frames]), 1 / 60, atol=sim.timestep)
    for frame in frames:  # the pose filmed is the simulation's at the frame's stamp, copied
        np.testing.assert_allclose(frame.qpos[:3], poses[frame.capture_time])
    assert not np.allclose(frames[0].qpos[:3], frames[-1].qpos[:3])


def test_the_frame_shows_the_ball_where_the_camera_projects_it():
    sim = TableSimulation()
    sim.reset(ball_position=(0.12, -0.31), ball_velocity=(0.0, 0.0))
    camera = LiveCamera(LiveCameraConfig(rate=60, width=320, height=240, noise=0.0))
    try:
        image = camera.capture(sim.data.qpos.copy())
    finally:
        camera.close()
    assert image.shape == (240, 320, 3) and image.dtype == np.uint8
    u, v = camera.camera.project(sim.ball_position()[None, :])[0]
    # The white ball is the brightest, least saturated thing at its projected centre; the felt around it is not.
    grey = image.astype(float).mean(axis=2)
    assert grey[int(round(v)), int(round(u))] > 180
    assert grey[int(round(v)) + 12, int(round(u))] < 150
    intrinsics = camera.intrinsics
    assert (intrinsics.width, intrinsics.height, ros_distortion_model(intrinsics)) == (320, 240, "plumb_bob")
    np.testing.assert_allclose(intrinsics.camera_matrix, camera.camera.camera_matrix())


@pytest.mark.parametrize("config, error, reason", [
    (LiveCameraConfig(rate=-1.0), RenderError, "camera_rate"),
    (LiveCameraConfig(rate=math.nan), RenderError, "camera_rate"),
    (LiveCameraConfig(rate=60, width=8), RenderError, "at least 16"),
    (LiveCameraConfig(rate=60, ball_colour="green"), RenderError, "ball colour"),
    (LiveCameraConfig(rate=60, camera="no_such_camera"), CameraConfigError, "not found"),
])
def test_a_bad_camera_is_refused_in_one_line(config, error, reason):
    with pytest.raises(error, match=reason) as raised:
        LiveCamera(config)
    assert "\n" not in str(raised.value)


def test_a_negative_camera_rate_is_refused_by_the_runner():
    with pytest.raises(ValueError, match="camera_rate"):
        SimRunner(TableSimulation(), RunnerConfig(camera_rate=-5.0))
