"""Spins as the tournament rules count them (foos_policy.spins): a sweep is a turn one way since the last reversal
or standstill."""
import pytest

from foos_policy.spins import FULL_TURN, SweepTracker


def test_a_rod_turning_on_past_a_full_turn_spins():
    sweeps = SweepTracker([0.0, 0.0])
    for k in range(1, 15):  # rod 0 turns 0.5 rad a step (25 rad/s), rod 1 stands still
        sweeps.update([0.5 * k, 0.0])
        assert sweeps.spinning()[0] == (0.5 * k > FULL_TURN)
    assert not sweeps.spinning()[1]
    assert sweeps.turned == pytest.approx([7.0, 0.0])


def test_a_reversal_or_a_standstill_starts_a_new_sweep():
    sweeps = SweepTracker([0.0])
    for angle in (2.0, 4.0, 6.0, 5.0):  # back by 1 rad after 6
        sweeps.update([angle])
    assert sweeps.swept()[0] == 1.0 and not sweeps.spinning()[0]
    for angle in (1.0, -3.0):  # on backwards: 8 rad one way since the reversal at 6
        sweeps.update([angle])
    assert sweeps.swept()[0] == 9.0 and sweeps.spinning()[0]
    sweeps.update([-3.005])  # stood still for a step
    sweeps.update([-5.0])
    assert sweeps.swept()[0] == pytest.approx(2.0) and not sweeps.spinning()[0]  # counted from where it stood
    sweeps.reset([10.0])
    assert sweeps.swept()[0] == 0.0 and sweeps.turned[0] == 0.0

