"""The accuracy benchmark at a small size: it runs end to end and its figures are sane.

The full-size figures against the issue's targets come from ./scripts/bench_vision (docs/vision.md)."""
from __future__ import annotations

import math

import pytest

from foos_core.table_params import SERVO_REFERENCE_PARAMS_FILE
from foos_vision import bench
from foos_vision.bench import CASES, run


@pytest.fixture
def former_drives(monkeypatch):
    """The bench's games on the former velocity servos (params/servo_reference_table.yaml): its seeded scenes
    were made with them; on the jerk-limited drives the oblique orange case's ball was lost (recall 0)."""
    monkeypatch.setattr(bench, "REFERENCE_PARAMS_FILE", SERVO_REFERENCE_PARAMS_FILE)


@pytest.mark.timeout(170)
def test_bench_small(tmp_path, former_drives):
    lines: list[str] = []
    cases = [c for c in CASES if c.name in ("overhead-640-120-red-lens", "oblique-640-60-orange")]
    results = run(0.6, cases, tmp_path, seed=7, echo=lines.append)
    text = "\n".join(lines)
    assert "median" in text and "throughput 640x480" in text and "onl%" in text
    # Each case is tracked without and with the figure mask (fed the rendered joints): rows alternate.
    assert [r["case"] for r in results] == [n for c in cases for n in (c.name, c.name + "+mask")], text
    for plain, masked in zip(results[::2], results[1::2]):
        assert masked["half_visible_frames"] == plain["half_visible_frames"], text
        # 30 frames of a ball next to figures: the mask moves a few partly hidden frames' centres by 1-3 mm
        # (the oblique case at this size: median 3.6 -> 4.2 mm); over 4 s it is no worse (docs/vision.md).
        assert masked["median_mm"] < plain["median_mm"] + 1.0, text
    for r in results:
        assert r["colour"] == ("red" if "red" in r["case"] else "orange"), r
        assert r["detections"] > 0.5 * r["frames"], r
        assert r["median_mm"] < (5.0 if r["case"].endswith("+mask") else 4.0), text
        assert r["recall"] > 0.8, text
        # The backward pass only adds frames before a track's start to what the forward pass found.
        assert r["recall"] >= r["online_recall"] and r["half_visible_frames"] > 0, text
        assert r["false_per_1000"] == 0 or math.isnan(r["false_per_1000"]), text
        assert r["speed_err_kf"] < 0.5 and r["speed_err_cd"] < 0.5, text
        assert r["fps_track"] > 20, text
