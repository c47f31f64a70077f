"""A camera alone: a rolling segment that is really two rolls (a touch the rod-line rule missed) is cut at the
touch, and a roll on a tilted table is left whole (foos_calibration.hidden_touches)."""
import numpy as np
import pytest

from foos_calibration.fitting import SegmentBatch
from foos_calibration.hidden_touches import split_hidden_touches
from foos_calibration.mjsim import theta_of
from foos_calibration.tracks import Segment
from foos_core.table_params import load_params

NOISE = 0.0015
FPS = 120.0


def roll(theta, position, velocity, seconds, t0=0.0):
    """Positions of a ball rolling from (position, velocity) under the table model theta, at FPS."""
    t = t0 + np.arange(int(seconds * FPS)) / FPS
    segment = Segment(0, 0, t, np.zeros((len(t), 2)))
    batch = SegmentBatch([segment])
    state = np.array([[*position, *velocity, 0.0, 0.0]])
    return t, batch.predict(state, theta[None])[0, : len(t)]


def noisy(xy, rng):
    return xy + rng.normal(0.0, NOISE, xy.shape)


@pytest.fixture(scope="module")
def theta():
    return theta_of(load_params())


def test_a_touch_inside_a_segment_is_cut_there(theta):
    rng = np.random.default_rng(4)
    t1, xy1 = roll(theta, (-0.2, -0.1), (0.8, 0.3), 0.4)
    # a figure's glancing touch: the ball goes on from where it was, turned by about 0.2 m/s
    t2, xy2 = roll(theta, xy1[-1] + (xy1[-1] - xy1[-2]), (0.75, 0.5), 0.4, t0=t1[-1] + 1 / FPS)
    segment = Segment(0, 0, np.concatenate([t1, t2]), noisy(np.concatenate([xy1, xy2]), rng))
    pieces, cuts = split_hidden_touches([segment], NOISE)
    assert cuts >= 1 and len(pieces) == 2
    assert pieces[0].t[-1] < t2[0] <= pieces[1].t[0] and pieces[1].t[0] - pieces[0].t[-1] < 0.1


@pytest.mark.parametrize("slope", [0.0, 0.006])
def test_a_plain_roll_stays_whole_even_on_a_tilted_table(theta, slope):
    rng = np.random.default_rng(5)
    tilted = theta.copy()
    tilted[0] = slope  # theta's first two terms are the tilt's slopes
    t, xy = roll(tilted, (-0.25, 0.1), (0.9, -0.2), 0.8)
    pieces, cuts = split_hidden_touches([Segment(0, 0, t, noisy(xy, rng))], NOISE)
    assert cuts == 0 and len(pieces) == 1
