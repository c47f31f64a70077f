"""bench_vision --real: clips read and scored, bad input refused in one line; the real footage where it is at hand.

The real footage (../shared/realdata, see its README) may not be copied into the repository: the tests that use it
skip where it is absent. The others build their clips from frames drawn here."""
from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import cv2
import numpy as np
import pytest

from foos_vision.real_bench import Clip, read_clip, read_visibility, score

REALDATA = Path(__file__).resolve().parents[2] / ".." / "shared" / "realdata"


def bench(*args: str, timeout: float = 300) -> subprocess.CompletedProcess:
    return subprocess.run([sys.executable, "-m", "foos_vision.bench", *args], capture_output=True, text=True,
                          timeout=timeout)


def write_frame(path: Path, size=(320, 240)) -> None:
    cv2.imwrite(str(path), np.full((size[1], size[0], 3), 90, np.uint8))


def test_scores_follow_the_issue_definitions():
    # Labels: ball 10 px wide. Frame 0 found (4 px off), 1 between one and two diameters (neither found nor false),
    # 2 more than two diameters off (false), 3 a frame with no ball label (false), 4 missed.
    labels = {0: [(100.0, 100.0, 10.0)], 1: [(100.0, 100.0, 10.0)], 2: [(100.0, 100.0, 10.0)], 3: [],
              4: [(50.0, 50.0, 10.0)]}
    clip = Clip("c", Path("."), labels=labels)
    detections = {0: (104.0, 100.0), 1: (115.0, 100.0), 2: (130.0, 100.0), 3: (10.0, 10.0)}
    r = score(clip, detections, 5, "frames")
    assert (r.scored, r.found, r.detections, r.false) == (4, 1, 4, 2)
    assert sorted(r.errors) == [4.0, 15.0]


def test_visibility_list_scores_found_and_false_only(tmp_path):
    listed = tmp_path / "visible.yaml"
    listed.write_text("visible: 0-2, 5\nends_in: home_goal\n")
    visible, ends_in = read_visibility(listed)
    assert visible == {0, 1, 2, 5} and ends_in == "home_goal"
    clip = Clip("c", tmp_path, visible=visible)
    r = score(clip, {0: (1.0, 1.0), 2: (1.0, 1.0), 3: (1.0, 1.0)}, 8, "video")
    assert (r.scored, r.found, r.detections, r.false, r.errors) == (4, 2, 3, 1, [])


def test_yolo_labels_of_frames_are_read_in_pixels(tmp_path):
    write_frame(tmp_path / "7.jpg")
    (tmp_path / "7.txt").write_text("1 0.5 0.5 0.1 0.2\n0 0.25 0.5 0.05 0.0625\n")
    clip = read_clip(tmp_path)
    assert clip.stills and clip.labels == {0: [(80.0, 120.0, 16.0)]}


@pytest.mark.parametrize("files, message", [
    ({"3.txt": "0 0.5 0.5 0.1 0.1\n"}, "no frames and no video"),
    ({"3.jpg": None, "3.txt": "0 0.5 0.5 0.1\n"}, "not a YOLO label"),
    ({"3.jpg": None, "3.txt": "ball at 12,40\n"}, "not a YOLO label"),
    ({"3.jpg": None, "3.txt": "0 1.5 0.5 0.1 0.1\n"}, "not a YOLO label"),
    ({"3.jpg": None}, "no labels"),
    ({"clip.mp4": "not a video", "visible.yaml": "visible: 0-3\n"}, "cannot open as a video"),
    ({"3.jpg": None, "visible.yaml": "visible: all of them\n"}, "not a frame index"),
])
def test_bad_input_is_one_line_and_exit_2(tmp_path, files, message):
    for name, text in files.items():
        if text is None:
            write_frame(tmp_path / name)
        else:
            (tmp_path / name).write_text(text)
    result = bench("--real", str(tmp_path), timeout=60)
    assert result.returncode == 2, result.stdout + result.stderr
    lines = result.stderr.strip().splitlines()
    assert len(lines) == 1 and lines[0].startswith("bench_vision: error:") and message in lines[0], result.stderr


def test_missing_folder_is_refused(tmp_path):
    result = bench("--real", str(tmp_path / "nowhere"), timeout=60)
    assert result.returncode == 2 and "no such folder" in result.stderr


@pytest.mark.skipif(not (REALDATA / "goal5" / "goal5.mp4").exists(), reason="../shared/realdata/goal5 is absent")
@pytest.mark.timeout(300)
def test_goal5_row():
    result = bench("--real", str(REALDATA / "goal5"))
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("goal5 "))
    fields = row.split()  # clip, mode ("video, tags"), frames, ball, found, recall, med, p95, dets, false, ...
    frames, ball, found, false = (int(fields[k]) for k in (3, 4, 5, 10))
    assert (frames, ball) == (108, 39), row
    assert found >= 36, row  # 33 before the motion search (docs/measurements/vision-2026-11-27-real-footage.md)
    assert false == 0, row
    assert "in the home goal mouth" in result.stdout, result.stdout


@pytest.mark.skipif(not (REALDATA / "leonhart").is_dir(), reason="../shared/realdata/leonhart is absent")
@pytest.mark.timeout(300)
def test_leonhart_row():
    result = bench("--real", str(REALDATA / "leonhart"))
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("leonhart "))
    assert "stills, field found" in row and " 41 " in row, row
    fields = row.split()  # clip, mode ("stills, field found"), frames, ball, found, recall, med, p95, dets, false, ...
    found, false = int(fields[6]), int(fields[11])
    # 11 found and 27 false before the candidates were scored on shape, outline and team colour (27 Nov), 26 and 3
    # after (docs/measurements/vision-2026-11-27-stills.md); 24 and 0 once a pick must lead its rivals and be round
    # (vision-2026-11-28-stills.md); 27 and 1 once the light on the rods' lines is taken out (vision-2026-11-28-
    # stills-2.md: the wrong pick is frame 287's painted penalty spot, at the floor, with the ball not a candidate
    # and the rod reflections that outscored the spot gone); 28 and 1 once a ball's tint is a second cue where the
    # light has no clear ball (vision-2026-11-28-stills-3.md); 29 and 0 once frames are searched at 1280 px and a tint
    # pick needs 0.7 (vision-2026-11-28-stills-4.md). The issue's target is 33 found and 2 wrong.
    assert found >= 29 and false == 0, row


@pytest.mark.timeout(180)
def test_a_labelled_sequence_of_frames_with_markers_is_tracked_and_scored(tmp_path):
    # Drawn frames with real tags (drawn_table), an orange ball rolling, YOLO labels from the truth, the markers file:
    # the tracker's own detections are scored against the labels.
    from .drawn_table import draw_ball, table_frame, to_pixel, write_layout

    clip = tmp_path / "drawn"
    clip.mkdir()
    write_layout(clip / "markers.yaml")
    for k in range(30):
        x, y = -0.2 + 0.01 * k, -0.3 + 0.02 * k
        frame = table_frame()
        draw_ball(frame, x, y)
        cv2.imwrite(str(clip / f"frame_{k:03d}.png"), cv2.GaussianBlur(frame, (3, 3), 0.7))
        u, v = to_pixel(x, y)
        (clip / f"frame_{k:03d}.txt").write_text(f"0 {u / 640:.6f} {v / 480:.6f} {14 / 640:.6f} {14 / 480:.6f}\n")
    (clip / "frame_030.png").write_bytes((clip / "frame_000.png").read_bytes())  # a frame with no ball label file
    result = bench("--real", str(clip))
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("drawn "))
    fields = row.split()  # clip, mode ("frames, tags"), frames, ball, found, recall, med, p95, dets, false, ...
    frames, ball, found, median, false = int(fields[3]), int(fields[4]), int(fields[5]), float(fields[7]), int(fields[10])
    assert (frames, ball) == (31, 30), row
    assert found >= 27 and median < 1.0 and false == 0, row


@pytest.mark.skipif(not (REALDATA / "goal5" / "goal5.mp4").exists(), reason="../shared/realdata/goal5 is absent")
@pytest.mark.timeout(300)
def test_goal5_as_stills():
    # The video's frames one by one, its tags unused: the felt is found in each frame and the pick must lead its
    # rivals, so no frame with the ball out of sight reports one (vision-2026-11-28-stills.md: 15 of 39, 0 false; 16
    # once the rods' light is taken out, vision-2026-11-28-stills-2.md; 21 with the tint cue, vision-2026-11-28-
    # stills-3.md, each within 4.2 px of the tracker's own detection; the same 21 at 1280 px, vision-2026-11-28-
    # stills-4.md).
    result = bench("--real", str(REALDATA / "goal5"), "--stills")
    assert result.returncode == 0, result.stderr
    row = next(line for line in result.stdout.splitlines() if line.startswith("goal5 "))
    assert "stills, field found" in row and "no field" not in result.stdout and "goal mouth" not in result.stdout, row
    fields = row.split()  # clip, mode ("stills, field found"), frames, ball, found, recall, med, p95, dets, false, ...
    frames, ball, found, false = int(fields[4]), int(fields[5]), int(fields[6]), int(fields[11])
    assert (frames, ball) == (108, 39) and found >= 21 and false == 0, row


def test_stills_needs_real():
    result = bench("--stills", timeout=60)
    assert result.returncode == 2 and "--stills goes with --real" in result.stderr, result.stderr


@pytest.mark.timeout(300)
def test_throughput_rows_give_decoding_alone_and_with_tracking(overhead_video):
    # In a process of its own: the throughput run pins itself to one core.
    from ..user_env import workspace_env

    markers = overhead_video.with_suffix(".markers.yaml")
    code = ("from pathlib import Path; from foos_core.markers import load_markers; "
            "from foos_vision.throughput import run_throughput; "
            f"run_throughput([('overhead', Path('{overhead_video}'), load_markers('{markers}'), None)], repeats=2)")
    env = dict(workspace_env(), OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1")
    result = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env, timeout=240)
    assert result.returncode == 0, result.stderr
    lines = result.stdout.splitlines()
    assert "pinned to core" in lines[0] and "OPENBLAS" not in lines[0], lines[0]
    fields = next(line for line in lines if line.startswith("overhead ")).split()
    # clip, size, frames, dec fps, fps, ratio, track ms, target verdict, runs
    frames, decode, tracked, ratio, tracker_ms = int(fields[2]), float(fields[3]), float(fields[4]), float(fields[5]), float(fields[6])
    assert frames == 73  # 1.2 s at 60 fps, the first frame at 0 and the last at 1.2 s
    assert 0 < tracked < decode and 0 < ratio < 1 and tracker_ms > 0, fields
    assert fields[7] in ("met", "missed") and len(fields[8:]) == 2  # the two runs, decoding alone / with tracking


@pytest.mark.timeout(180)
def test_per_frame_lines_of_stills(tmp_path):
    # Drawn stills (test_still_ball.drawn_still: a 35 mm ball 40.6 px wide at (1200, 500)) with YOLO labels: one found,
    # one with a second ball alike (a guess: no pick, the labelled ball still a candidate), one labelled where no ball
    # is (the pick is then wrong, and nothing near the label is a candidate), one with no ball and an empty label.
    from foos_vision.detection.still_ball import MIN_SCORE
    from foos_vision.real_bench import per_frame_lines, run_real

    from .test_still_ball import drawn_still

    twin = drawn_still()
    cv2.circle(twin, (600, 800), 20, (235, 235, 235), -1, cv2.LINE_AA)
    frames = {"a": (drawn_still(), (1200, 500)), "b": (twin, (600, 800)), "c": (drawn_still(), (400, 250)),
              "d": (drawn_still(ball=None), None)}
    for stem, (image, label) in frames.items():
        cv2.imwrite(str(tmp_path / f"{stem}.png"), image)
        text = f"0 {label[0] / 1920:.6f} {label[1] / 1080:.6f} {40 / 1920:.6f} {40 / 1080:.6f}\n" if label else ""
        (tmp_path / f"{stem}.txt").write_text(text)
    printed: list[str] = []
    run_real(tmp_path, echo=printed.append, per_frame=True)
    lines = [line.strip() for line in printed if line.startswith("    ")]
    assert len(lines) == 4, printed
    a, b, c, d = lines
    assert a.startswith("a.png: found: label (1200, 500); pick (") and "px off" in a and "candidate" not in a, a
    assert b.startswith("b.png: missed: label (600, 800); no pick; ball's best candidate: rank ") and ", light, score " \
        in b, b
    assert b.split("rank ")[1].split(",")[0] in ("1", "2") and float(b.split("score ")[1]) >= MIN_SCORE, b
    assert c.startswith("c.png: wrong: label (400, 250); pick ("), c
    u, v = (float(x) for x in c.split("pick (")[1].split(")")[0].split(","))
    off = float(c.split("pick (")[1].split(") ")[1].split(" px off")[0])
    assert math.hypot(u - 1200, v - 500) < 4 and abs(off - math.hypot(u - 400, v - 250)) < 1, c
    assert c.endswith("no candidate within a diameter"), c
    assert d == "d.png: none: no ball labelled; no pick", d
    # The same frames without a field's worth of felt are no still's lines: per_frame_lines is score's verdicts alone.
    clip = read_clip(tmp_path)
    assert per_frame_lines(clip, {}, 4)[0] == "a.png: missed: label (1200, 500); no pick", per_frame_lines(clip, {}, 4)


def test_per_frame_needs_stills():
    result = bench("--real", "somewhere", "--per-frame", timeout=60)
    assert result.returncode == 2 and "--per-frame goes with --real DIR --stills" in result.stderr, result.stderr
