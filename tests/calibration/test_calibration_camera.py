"""End to end through the camera: render a video of a table with a hidden tilt, track it, calibrate.

Rendering 20 s of 640x480 video costs 1.5 min on an idle 2-core machine (7 min under load), over
this area's test budget, so the test runs only with FOOS_SLOW_TESTS=1:
    FOOS_SLOW_TESTS=1 python -m pytest tests/calibration/test_calibration_camera.py
"""
from __future__ import annotations

import json
import math
import os

import pytest

pytestmark = pytest.mark.skipif(os.environ.get("FOOS_SLOW_TESTS") != "1",
                                reason="slow camera end-to-end test; set FOOS_SLOW_TESTS=1")


@pytest.mark.timeout(1200)
def test_tilt_hidden_in_a_rendered_video_is_found(tmp_path, ros_env):
    import subprocess

    def run(*args, timeout=900):
        result = subprocess.run(["ros2", "run", *args], capture_output=True, text=True, timeout=timeout,
                                env=ros_env, cwd=tmp_path)
        assert result.returncode == 0, result.stderr
        return result

    table = tmp_path / "tilted.yaml"
    table.write_text("base: regulation_table\neffects:\n  - {name: table_tilt, params: {slope_x: 0.008, slope_y: 0.0}}\n")
    video = tmp_path / "rolls.mp4"
    run("foos_vision", "render_video", str(video), "--scenario", "rolls", "--duration", "20", "--fps", "60",
        "--params-file", str(table), "--seed", "3", "--quiet")
    run("foos_vision", "track_video", str(video), "--markers", str(tmp_path / "rolls.markers.yaml"),
        "--out", str(tmp_path / "bag"), "--quiet")
    run("foos_sim", "calibrate", str(tmp_path / "bag"), "--out", str(tmp_path / "out"), "--max-starts", "10",
        "--no-figures", "--quiet")
    report = json.loads((tmp_path / "out" / "report.json").read_text())
    found = {e["name"]: e["params"] for e in report["effects"]}
    assert "table_tilt" in found, report["effects"]
    tilt = found["table_tilt"]
    assert math.hypot(tilt["slope_x"] - 0.008, tilt["slope_y"]) <= 0.2 * 0.008, tilt
