"""The synthetic measured-data generator: its hidden forces show the contract's numbers, and its bag
is what a tracker would record."""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from foos_bag import read_ball_detections, topics
from foos_calibration import generate as gen
from foos_calibration import surrogate
from foos_calibration.fitting import SegmentBatch, fit_states
from foos_calibration.tracks import analyse
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params


def test_hidden_tilt_and_viscous_forces_match_the_surrogate_a_calibration_fits():
    # Same physics, different mechanism: forces on the nominal MuJoCo model vs the point model.
    effects = [{"name": "table_tilt", "params": {"slope_x": 0.006, "slope_y": -0.004}},
               {"name": "viscous_damping", "params": {"rate": 0.2}},
               {"name": "surface_dent", "params": {"x": 0.0, "y": 0.1, "radius": 0.1, "depth": 0.003}}]
    hidden = gen.HiddenEffects.from_effects(effects)
    table = gen.HiddenTable(hidden)
    table.reset((0.05, -0.3), (0.1, 0.9))
    times, positions = table.roll(0.8)
    theta = gen.surrogate_theta(hidden)[None]
    point = surrogate.integrate(np.array([[0.05, -0.3]]), np.array([[0.1, 0.9]]), theta, 96, 1 / 120)[0]
    measured = np.stack([np.interp(np.arange(97) / 120, times, positions[:, k]) for k in range(2)], axis=1)
    assert np.max(np.linalg.norm(point - measured, axis=1)) < 0.002


@pytest.mark.parametrize("velocity", [(1.2, 0.4), (0.6, 0.1), (0.4, -1.0)])
def test_the_point_models_slide_after_a_bounce_follows_mujoco(velocity):
    # After a wall bounce the MuJoCo ball slides until friction matches its spin. The fit's point model
    # has a slip for that; without it the segment after the bounce misfits by 0.2-5 mm.
    params = load_params()
    table = gen.HiddenTable(gen.HiddenEffects(), params)
    table.reset((0.0, 0.0), velocity)
    times, positions = table.roll(3.0)
    frames = np.arange(0.0, times[-1], 1 / 120)
    xy = np.stack([np.interp(frames, times, positions[:, k]) for k in (0, 1)], axis=1)
    slides = [s for s in analyse(frames, xy, TableGeometry.from_params(params)).segments if s.slide]
    assert slides
    segment = slides[0]
    with_slip = fit_states(SegmentBatch([segment]), surrogate.nominal_theta())
    rolling_only = fit_states(SegmentBatch([replace(segment, slide=False, slip_guess=None)]), surrogate.nominal_theta())
    rms = np.sqrt(with_slip.rss / len(segment.t))
    assert rms < 0.0003
    assert rms < 0.2 * np.sqrt(rolling_only.rss / len(segment.t))
    # The contact point slips away from the wall: the bounce turned the velocity, not the spin.
    assert np.dot(with_slip.states[0, 4:6], segment.slip_guess) > 0
    assert surrogate.SLIDING_FRICTION == params["ball"]["sliding_friction"]


def test_hidden_restitution_changes_the_bounce():
    hidden = gen.HiddenEffects.from_effects([{"name": "wall_restitution", "params": {"coefficient": 0.5}}])
    table = gen.HiddenTable(hidden)
    table.reset((0.28, 0.0), (1.0, 0.0))
    times, positions = table.roll(0.12, sample_dt=1e-3)
    # Right after the bounce (at 43 ms) the ball comes back at half its speed; sliding friction acts after.
    x = positions[:, 0]
    back = (times > 0.046) & (times < 0.056)
    v_out = -np.polyfit(times[back], x[back], 1)[0]
    assert v_out == pytest.approx(0.5, abs=0.04)


def test_recording_looks_like_a_camera_and_goes_through_a_bag(tmp_path):
    rec = gen.generate([], duration=12.0, seed=3)
    dt = np.diff(rec.t)
    assert np.all(dt > 0)
    assert np.min(dt) == pytest.approx(1 / 120, abs=1e-6)  # 120 fps frames
    assert 0.0 < np.mean(dt > 1.5 / 120) < 0.3  # dropouts and pick-up gaps
    truth = np.stack([np.interp(rec.t, rec.truth_t, rec.truth_position[:, k]) for k in range(2)], axis=1)
    noise = rec.position[:, :2] - truth
    assert np.std(noise) == pytest.approx(0.0015, rel=0.15)
    bag = tmp_path / "bag"
    gen.write_bag(rec, bag)
    assert set(topics(bag)) == {"/ball/detection"}
    back = read_ball_detections(bag)
    assert back.frame_id == "table" and np.allclose(back.t, rec.t, atol=1e-9) and np.allclose(back.position, rec.position)


def test_generate_measured_cli(ros2_run, tmp_path):
    result = ros2_run("generate_measured", str(tmp_path / "bag"), "--duration", "5", "--effect",
                      "table_tilt:slope_x=0.005,slope_y=0", "--truth", str(tmp_path / "truth.json"))
    assert result.returncode == 0, result.stderr
    assert (tmp_path / "bag" / "metadata.yaml").exists() and "table_tilt" in (tmp_path / "truth.json").read_text()
    bad = ros2_run("generate_measured", str(tmp_path / "bag2"), "--effect", "warp_drive:x=1")
    assert bad.returncode == 2 and "unknown effect" in bad.stderr and "Traceback" not in bad.stderr
    again = ros2_run("generate_measured", str(tmp_path / "bag"), "--duration", "2")
    assert again.returncode == 2 and len(again.stderr.strip().splitlines()) == 1 and "Traceback" not in again.stderr
