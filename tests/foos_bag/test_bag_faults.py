"""The recorder under SIGINT, SIGTERM and SIGKILL, checked message by message against what was published."""
from __future__ import annotations

import signal
import time

import numpy as np
import pytest

from foos_bag import BagError, messages, topics

from .helpers import load_log, run_cli

pytestmark = pytest.mark.dds

TOPICS = ["/load/t0", "/load/t1"]
RATE = 200.0  # Hz per topic
# Delivery over loopback DDS on a loaded 2-core machine: a message published this long before the
# signal has certainly reached the recorder.
DELIVERY = 0.5


def record_then_signal(launch, tmp_path, domain: int, sig: int, storage: str, executor: str = "single"):
    bag = tmp_path / "bag"
    rec = launch(["ros2", "bag", "record", *TOPICS, "-o", str(bag), "-s", storage, "--executor", executor],
                 "recorder", domain)
    rec.wait_for("Recording", 30)
    pub = launch(
        ["ros2", "run", "foos_bag", "load_publisher", "--rate", str(RATE), "--topics", str(len(TOPICS)),
         "--duration", "60", "--wait-subscribers", "1", "--log", str(tmp_path / "pub.json")],
        "publisher", domain,
    )
    rec.wait_for("Subscribed to topic", 30, count=len(TOPICS))
    time.sleep(2.0)
    signal_ns = time.time_ns()
    rec.signal(sig)
    rc = rec.wait(20)
    time.sleep(0.3)
    pub.signal(signal.SIGINT)
    assert pub.wait(20) == 0, pub.text()
    return bag, rc, signal_ns, load_log(tmp_path / "pub.json"), rec


def check_kept(bag, published, signal_ns: int, lost_window: float) -> int:
    """Kept messages are an unbroken run; everything published from the first kept message until
    `lost_window` + delivery before the signal is there; nothing published after the signal is."""
    total = 0
    for topic in TOPICS:
        msgs = [m for _, _, m in messages(bag, [topic])]
        seqs = np.array([int(m.point.x) for m in msgs])
        assert len(seqs) > RATE, f"{topic}: only {len(seqs)} messages kept"
        assert np.all(np.diff(seqs) == 1), f"{topic}: gaps or duplicates in the kept sequence"
        pub_times = np.array(published[topic])
        # Contents are exactly what was published: the stamp is the publish time of that sequence number.
        stamps = np.array([m.header.stamp.sec * 1_000_000_000 + m.header.stamp.nanosec for m in msgs])
        assert np.array_equal(stamps, pub_times[seqs])
        must_have = np.nonzero(pub_times < signal_ns - (lost_window + DELIVERY) * 1e9)[0]
        must_have = must_have[must_have >= seqs[0]]
        assert seqs[-1] >= must_have[-1], (
            f"{topic}: last kept #{seqs[-1]} but #{must_have[-1]} was published "
            f"{(signal_ns - pub_times[must_have[-1]]) / 1e9:.2f} s before the signal"
        )
        assert pub_times[seqs[-1]] <= signal_ns + int(DELIVERY * 1e9), f"{topic}: kept a message published after the stop"
        total += len(seqs)
    return total


@pytest.mark.timeout(90)
@pytest.mark.parametrize(
    "sig,storage,executor,domain",
    [(signal.SIGINT, "mcap", "single", 21), (signal.SIGTERM, "sqlite3", "single", 22),
     (signal.SIGTERM, "mcap", "events", 29)],
)
def test_clean_stop_keeps_everything_received(launch, tmp_path, sig, storage, executor, domain):
    bag, rc, signal_ns, published, rec = record_then_signal(launch, tmp_path, domain, sig, storage, executor)
    assert rc == 0, rec.text()
    assert "Recording stopped" in rec.text()
    kept = check_kept(bag, published, signal_ns, lost_window=0.0)
    assert sum(topics(bag)[t][1] for t in TOPICS) == kept  # metadata.yaml agrees with the files


@pytest.mark.timeout(90)
@pytest.mark.parametrize("storage,domain", [("mcap", 23), ("sqlite3", 24)])
def test_sigkill_then_reindex_recovers_what_was_flushed(launch, tmp_path, storage, domain):
    bag, rc, signal_ns, published, _ = record_then_signal(launch, tmp_path, domain, signal.SIGKILL, storage)
    assert rc == -signal.SIGKILL
    with pytest.raises(BagError, match="reindex"):
        topics(bag)
    result = run_cli(["ros2", "bag", "reindex", str(bag)], tmp_path)
    assert result.returncode == 0, result.stderr
    # The recorder flushes every 0.1 s; that is the most a SIGKILL may lose.
    check_kept(bag, published, signal_ns, lost_window=0.1)
    info = run_cli(["ros2", "bag", "info", str(bag)], tmp_path)
    assert info.returncode == 0 and "Topic: /load/t0" in info.stdout
