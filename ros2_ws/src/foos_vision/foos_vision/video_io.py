"""Video files in, with the checks a user needs when a file is missing, unreadable or cut short."""
from __future__ import annotations

import math
import os
from pathlib import Path
from typing import Iterator, Optional

# FFmpeg's own log lines ("moov atom not found") would precede our one-line error; quiet it (-8 = quiet).
os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")

import cv2  # noqa: E402
import numpy as np  # noqa: E402

from .errors import VideoError  # noqa: E402


class VideoReader:
    """Frames of a video file (or a camera device index) with capture times since its start."""

    def __init__(self, source: str | int, fps: Optional[float] = None):
        self.source = source
        if isinstance(source, str):
            path = Path(source)
            if not path.exists():
                raise VideoError(f"video not found: {source}")
            if path.is_dir():
                raise VideoError(f"{source} is a directory, not a video file")
        self.capture = cv2.VideoCapture(source if isinstance(source, int) else str(source))
        if not self.capture.isOpened():
            raise VideoError(f"{source}: cannot open as a video (not a video file, or a codec OpenCV lacks)")
        container_fps = float(self.capture.get(cv2.CAP_PROP_FPS) or 0.0)
        self.fps = float(fps) if fps else container_fps
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise VideoError(f"{source}: the video does not say its frame rate; give it with --fps")
        self.declared_frames = int(self.capture.get(cv2.CAP_PROP_FRAME_COUNT) or 0)
        self.width = int(self.capture.get(cv2.CAP_PROP_FRAME_WIDTH))
        self.height = int(self.capture.get(cv2.CAP_PROP_FRAME_HEIGHT))
        self.frames_read = 0

    def frames(self) -> Iterator[tuple[int, float, np.ndarray]]:
        """(index, time since the first frame = index / fps, BGR frame)."""
        while True:
            ok, frame = self.capture.read()
            if not ok or frame is None:
                break
            index = self.frames_read
            self.frames_read += 1
            yield index, index / self.fps, frame
        if self.frames_read == 0:
            raise VideoError(f"{self.source}: no frame could be decoded (corrupt or empty video)")

    def truncated(self) -> bool:
        """True when the file promised clearly more frames than could be decoded."""
        return self.declared_frames > 0 and self.frames_read < self.declared_frames - 2

    def close(self) -> None:
        self.capture.release()
