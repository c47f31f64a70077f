"""The compiled S-curve lanes (foos_sim.scurve_lanes) give the same bits as scurve.plan / evaluate in numpy: the
recurrence over the command events (scurve.follow) and the evaluation at samples (what drive_shaping fits with)."""
from __future__ import annotations

import numpy as np
import pytest

from foos_sim import scurve, scurve_lanes

ROTATE = (314.159, 9425.0, 36650.0)  # the robot table's rotations: speed, acceleration, jerk
SLIDE = (3.48, 104.0, 406.0)


def _commands(rng, events: int, lanes: int) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Commands like a game's on both kinds of drive: bang-bang at the limits, zeros, holds (a settled lane's plan
    only brakes: scurve.plan's brake_only), commands 1-30 ms apart; and each lane's limits (some capped low)."""
    event_t = np.cumsum(rng.uniform(0.001, 0.03, events))
    rotate = rng.random(lanes) < 0.5
    speed = np.where(rotate, ROTATE[0], SLIDE[0])
    goals = rng.choice([-1.0, -0.3, 0.0, 0.0, 0.5, 1.0], size=(events, lanes)) * speed * rng.uniform(0.2, 1.0, lanes)
    hold = rng.random((events, lanes)) < 0.6
    for k in range(1, events):
        goals[k, hold[k]] = goals[k - 1, hold[k]]
    accel = np.where(rotate, ROTATE[1], SLIDE[1]) * rng.choice([0.05, 0.3, 1.0], lanes)
    jerk = np.where(rotate, ROTATE[2], SLIDE[2])
    return event_t, goals, accel, jerk


def _same_bits(x: np.ndarray, y: np.ndarray) -> bool:
    return x.shape == y.shape and np.array_equal(x.view(np.int64), y.view(np.int64))


@pytest.mark.parametrize("seed", range(3))
def test_follow_gives_the_numpy_recurrences_bits(seed):
    rng = np.random.default_rng(seed)
    event_t, goals, accel, jerk = _commands(rng, 1500, 24)
    v, a = scurve.follow(event_t, goals, accel, jerk)
    v_ref, a_ref = scurve.follow_numpy(event_t, goals, accel, jerk)
    assert _same_bits(v, v_ref) and _same_bits(a, a_ref)
    assert np.abs(v).max() > 100.0  # the lanes moved at rotation speeds (not a trivially equal rest)


@pytest.mark.parametrize("ascending", [True, False])
def test_sampled_gives_numpy_advances_bits_at_every_sample(ascending):
    rng = np.random.default_rng(7)
    event_t, goals, accel, jerk = _commands(rng, 1200, 16)
    v_event, a_event = scurve.follow(event_t, goals, accel, jerk)
    # Samples from before the first event to past the last, denser and sparser than the events; lanes sharing a
    # recurrence under different delays (a latency sweep), as drive_shaping asks.
    sample_t = np.sort(rng.uniform(event_t[0] - 0.2, event_t[-1] + 0.3, 3000))
    if not ascending:
        sample_t = rng.permutation(sample_t)
    column = rng.integers(0, goals.shape[1], 40)
    shift = rng.choice([0.0, 0.0075, 0.0342, 0.15], 40)
    rows = [np.ascontiguousarray(x.T) for x in (v_event, a_event, goals)]  # a lane a row, as drive_shaping keeps them
    v, a = scurve_lanes.sampled(event_t, *rows, column, sample_t, shift, accel[column], jerk[column], True)
    v_only, _ = scurve_lanes.sampled(event_t, *rows, column, sample_t, shift, accel[column], jerk[column], False)

    shifted = sample_t[None, :] - shift[:, None]
    found = np.stack([np.searchsorted(event_t, sample_t - s, side="right") for s in shift]) - 1
    valid, k, lanes = found >= 0, np.maximum(found, 0), column[:, None]
    v_ref, a_ref, _ = scurve.advance(v_event[k, lanes], a_event[k, lanes], goals[k, lanes], accel[column][:, None],
                                     jerk[column][:, None], np.maximum(shifted - event_t[k], 0.0))
    assert (~valid).any() and valid.any()
    assert _same_bits(v, v_ref * valid) and _same_bits(a, a_ref * valid) and _same_bits(v_only, v)
