"""The held-out scoring of the rolling effects starts its fits where the all-data fit left them.

Each fold's segment states are refitted on the fold's own data under the other fold's parameters.
Started from each segment's quadratic guess, those state fits stop at their evaluation limit short of
the minimum on long recordings (82 segments of a 238 fps game: half the held-out scoring's time), and
the held-out error then carries how far each fit got as well as the model. Started from the all-data
fit of the same effects, a fit can only improve on it: with nothing free, no fold's held-out error is
above the all-data fit's error on that fold's segments.
"""
from __future__ import annotations

import numpy as np

from foos_calibration import generate as gen
from foos_calibration import surrogate
from foos_calibration.fitting import SegmentBatch, fit_states
from foos_calibration.select import HeldOut
from foos_calibration.tracks import analyse, validate
from foos_core.table_geometry import TableGeometry


def test_no_fold_is_scored_above_where_the_all_data_fit_left_it():
    recording = gen.generate([], duration=30.0, seed=3, fps=240.0)  # 17 segments, 13 of them slides after a bounce
    t, xy = validate(recording.t, recording.position[:, :2], "table")
    segments = analyse(t, xy, TableGeometry.nominal()).segments
    theta0 = surrogate.nominal_theta()
    full = fit_states(SegmentBatch(segments), theta0)  # as select_effects fits the nominal model
    held = HeldOut(segments, TableGeometry.nominal())
    rss, thetas = held.score((), full)
    for k in (0, 1):
        fold = held.batches[k]
        own = [i for i, s in enumerate(segments) if s.fold == k]
        at_full = float(np.sum(fold.residual_of(fold.predict(full.states[own], np.tile(theta0, (fold.n, 1)))) ** 2))
        # From the segments' quadratic guesses, fold 0 ended 0.016 noise variances above it.
        assert rss[k] <= at_full * (1 + 1e-12), (k, rss[k], at_full)
        assert np.array_equal(thetas[k], theta0)
