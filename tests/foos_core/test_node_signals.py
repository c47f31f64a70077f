"""foos_core.node_signals: Ctrl-C and SIGTERM set a flag the node's loop checks; a repeated signal quits
unless the node (the recorder) must finish what it is writing."""
from __future__ import annotations

import os
import signal

import pytest

from foos_core.node_signals import StopSignal


@pytest.fixture
def restored_handlers():
    saved = {sig: signal.getsignal(sig) for sig in (signal.SIGINT, signal.SIGTERM)}
    yield
    for sig, handler in saved.items():
        signal.signal(sig, handler)


@pytest.mark.parametrize("first", [signal.SIGINT, signal.SIGTERM])
def test_a_signal_sets_the_flag_and_a_second_one_quits(restored_handlers, first):
    stop = StopSignal()
    assert not stop.requested
    os.kill(os.getpid(), first)
    assert stop.requested
    with pytest.raises(KeyboardInterrupt):
        os.kill(os.getpid(), signal.SIGINT)


def test_a_recorder_is_not_cut_short_by_a_second_signal(restored_handlers):
    stop = StopSignal(repeat_quits=False)
    for _ in range(3):
        os.kill(os.getpid(), signal.SIGINT)
    os.kill(os.getpid(), signal.SIGTERM)
    assert stop.requested
