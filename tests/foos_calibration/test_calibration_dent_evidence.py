"""The held-out check for a dent that a single roll crossed: alternate frames of that roll.

One roll cannot vouch for itself against other rolls, so the dent is found on the even frames and
judged on the odd ones, and the other way round. It must clear twice the usual bar for a dent that
is there, and earn nothing for one that only soaks up the camera's noise.
"""
from __future__ import annotations

import numpy as np
import pytest

from foos_calibration import generate as gen
from foos_calibration import surrogate
from foos_calibration.fitting import SegmentBatch, dent_search, fit, fit_states
from foos_calibration.select import FRAME_SPLIT_EVIDENCE, dent_frame_split_drops
from foos_calibration.tracks import Segment

NOISE = 0.0015  # m, the camera's


def one_roll(effects, seed) -> list[Segment]:
    """One 0.9 s roll at 0.8 m/s past (3 cm from the centre of) where the dent is, if there is one."""
    table = gen.HiddenTable(gen.HiddenEffects.from_effects(effects))
    table.reset((0.13, -0.3), (0.0, 0.8))
    times, positions = table.roll(0.9)
    t = np.arange(0.0, times[-1], 1 / 120)
    xy = np.stack([np.interp(t, times, positions[:, k]) for k in (0, 1)], axis=1)
    xy += np.random.default_rng(seed).normal(0.0, NOISE, xy.shape)
    return [Segment(track=0, flight=0, t=t, xy=xy)]


def frame_split_evidence(segments) -> list[float]:
    """As select_effects does: the best dent on all the data, then judged on alternate frames."""
    theta0 = surrogate.nominal_theta()
    batch = SegmentBatch(segments)
    base = fit_states(batch, theta0)
    dent, _ = dent_search(batch, base)
    start = theta0.copy()
    start[5:9] = dent
    with_dent = fit(batch, surrogate.EFFECT_PARAMS["surface_dent"], start, base.states).theta
    return dent_frame_split_drops(segments, theta0, with_dent, NOISE**2)


@pytest.mark.parametrize("seed", [1, 2])
def test_a_dent_one_roll_crossed_earns_its_evidence_on_alternate_frames(seed):
    dent = {"name": "surface_dent", "params": {"x": 0.1, "y": 0.1, "radius": 0.08, "depth": 0.002}}
    drops = frame_split_evidence(one_roll([dent], seed))
    assert sum(drops) >= FRAME_SPLIT_EVIDENCE and min(drops) > 0, drops


@pytest.mark.parametrize("seed", [1, 2])
def test_noise_alone_earns_no_dent_on_alternate_frames(seed):
    drops = frame_split_evidence(one_roll([], seed))
    assert sum(drops) < FRAME_SPLIT_EVIDENCE / 4, drops
