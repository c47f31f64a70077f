"""The accuracy benchmark at a small size: it runs end to end and its figures are sane.

The full-size figures against the issue's targets come from ./scripts/bench_vision (docs/vision.md)."""
from __future__ import annotations

import math

import pytest

from foos_vision.bench import CASES, run


@pytest.mark.timeout(170)
def test_bench_small(tmp_path):
    lines: list[str] = []
    cases = [c for c in CASES if c.name in ("overhead-640-120-red-lens", "oblique-640-60-orange")]
    results = run(0.6, cases, tmp_path, seed=7, echo=lines.append)
    text = "\n".join(lines)
    assert "median" in text and "throughput 640x480" in text and "onl%" in text
    for r in results:
        assert r["colour"] == ("red" if "red" in r["case"] else "orange"), r
        assert r["detections"] > 0.5 * r["frames"], r
        assert r["median_mm"] < 4.0, text
        assert r["recall"] > 0.8, text
        # The backward pass only adds frames before a track's start to what the forward pass found.
        assert r["recall"] >= r["online_recall"] and r["half_visible_frames"] > 0, text
        assert r["false_per_1000"] == 0 or math.isnan(r["false_per_1000"]), text
        assert r["speed_err_kf"] < 0.5 and r["speed_err_cd"] < 0.5, text
        assert r["fps_track"] > 20, text
