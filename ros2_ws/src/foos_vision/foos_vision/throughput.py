"""`bench_vision --throughput`: frames per second of track_video's offline path on one core, decoding included, next
to decoding alone in the same run (issue 25: >= 120 frames/s on goal5 and on a 1280x720 render).

Each clip is run REPEATS times, alternately: decoding alone (every frame decoded at full resolution, as track_video
reads it), then decoding and tracking (each frame decoded and handed to the tracker, forward pass and backward pass,
as track_video does), so that other jobs on a shared machine weigh on both alike. The ball's colour is chosen before
(choose_colour, as real_bench and the render bench do), outside the timing. Times are CPU seconds of this process
(time.process_time), the process pinned to one core (the first it may run on: `taskset -c 0` for the issue's figure)
with OpenCV's threads off; the rows give the medians, their ratio, and the tracker's own cost per frame
(1 / tracked - 1 / decoded).
"""
from __future__ import annotations

import os
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Optional

import cv2
import numpy as np

from foos_core.camera_model import Intrinsics

from .camera.field_corners import FieldReference
from .tracking.backfill import OfflineTracker
from .tracking.tracker import BallTracker, TrackerConfig, choose_colour
from .video_io import VideoReader

TARGET_FPS = 120.0  # issue 25: goal5 and a 1280x720 render, decoding included, one core
REPEATS = 5


@dataclass
class ThroughputRow:
    clip: str
    size: tuple[int, int]
    frames: int
    decode_fps: list[float]
    track_fps: list[float]  # decoding included
    detections: int

    @property
    def decode(self) -> float:
        return float(np.median(self.decode_fps))

    @property
    def track(self) -> float:
        return float(np.median(self.track_fps))

    @property
    def tracker_ms(self) -> float:
        """The tracker's own CPU time per frame, from the two medians."""
        return 1000.0 * (1.0 / self.track - 1.0 / self.decode)


def one_core() -> str:
    """Pin this process to the first core it may run on; says which (or why not)."""
    if not hasattr(os, "sched_setaffinity"):
        return "not pinned (no sched_setaffinity here)"
    allowed = sorted(os.sched_getaffinity(0))
    os.sched_setaffinity(0, {allowed[0]})
    # OpenBLAS starts its threads when numpy is imported, before this: held to one core, they wait on each other (a
    # dot product of 12k values took 19 ms). scripts/bench_vision sets the variable before Python starts.
    blas = "" if os.environ.get("OPENBLAS_NUM_THREADS") == "1" else "; OPENBLAS_NUM_THREADS is not 1: BLAS threads share it"
    return f"pinned to core {allowed[0]}{blas}"


def _decode(video: Path) -> tuple[int, float]:
    reader = VideoReader(str(video))
    try:
        started = time.process_time()
        frames = sum(1 for _ in reader.frames())
        return frames, time.process_time() - started
    finally:
        reader.close()


def _decode_and_track(video: Path, layout: FieldReference, config: TrackerConfig) -> tuple[int, float, int]:
    reader = VideoReader(str(video))
    try:
        tracker = BallTracker(layout, config)  # the table's files are read here, before the clock starts
        started = time.process_time()
        offline = OfflineTracker(tracker, reader.fps)
        frames = 0
        for index, t, frame in reader.frames():
            offline.process(index, t, frame)
            frames += 1
        offline.finish()
        return frames, time.process_time() - started, len(offline.results())
    finally:
        reader.close()


def measure(name: str, video: Path, layout: FieldReference, intrinsics: Optional[Intrinsics] = None,
            params_file: Optional[str] = None, repeats: int = REPEATS) -> ThroughputRow:
    reader = VideoReader(str(video))
    fps, size = reader.fps, (reader.width, reader.height)
    probe = [frame for index, _, frame in reader.frames() if index < 10 * fps]
    reader.close()
    config = TrackerConfig(intrinsics=intrinsics, params_file=params_file)
    config.ball_color = choose_colour(iter(probe), layout, config, fps) or "auto"
    del probe
    decode_fps, track_fps, detections, frames = [], [], 0, 0
    for _ in range(repeats):
        frames, seconds = _decode(video)
        decode_fps.append(frames / seconds)
        frames, seconds, detections = _decode_and_track(video, layout, config)
        track_fps.append(frames / seconds)
    return ThroughputRow(name, size, frames, decode_fps, track_fps, detections)


HEADER = (f"{'clip':<26} {'size':>9} {'frames':>6} {'dec fps':>8} {'fps':>7} {'ratio':>6} {'track ms':>8} "
          f"{'target':>6}  runs (dec / dec+track)")


def format_row(r: ThroughputRow) -> str:
    runs = ", ".join(f"{d:.0f}/{t:.0f}" for d, t in zip(r.decode_fps, r.track_fps))
    verdict = "met" if r.track >= TARGET_FPS else "missed"
    return (f"{r.clip:<26} {r.size[0]:>4}x{r.size[1]:<4} {r.frames:>6} {r.decode:>8.0f} {r.track:>7.0f} "
            f"{r.track / r.decode:>6.2f} {r.tracker_ms:>8.2f} {verdict:>6}  {runs}")


def run_throughput(clips: list[tuple[str, Path, FieldReference, Optional[Intrinsics]]], repeats: int = REPEATS,
                   params_file: Optional[str] = None, echo=print) -> list[ThroughputRow]:
    cv2.setNumThreads(1)
    echo(f"throughput on one core ({one_core()}), CPU seconds of this process, medians of {repeats} runs; "
         f"fps = decoding and tracking, target >= {TARGET_FPS:.0f}; ratio = fps / decoding alone")
    echo(HEADER)
    rows = []
    for name, video, layout, intrinsics in clips:
        row = measure(name, video, layout, intrinsics, params_file, repeats)
        rows.append(row)
        echo(format_row(row))
    return rows
