"""`bench_vision --real DIR`: the tracker scored on real footage, a row per clip.

DIR is a clip, or a folder of clips (one per sub-folder). A clip is a folder holding
- footage: one video file, or frames (.jpg/.png, in the order of the number in their names);
- what fixes the field: a markers YAML (the tags' centres, as track_video --markers), or `field_corners.txt`
  (U1,V1,...,U4,V4, as --field-corners). A folder of frames with neither is scored as single stills: each frame
  alone, the field found in it (still_ball), no time order (a camera that pans and zooms between frames).
  `--stills` scores every clip that way, a video or a clip with markers too;
- the truth: YOLO labels (`class cx cy w h`, normalised to the image, class 0 = the ball), one `.txt` per frame with
  the frame's name (stills) or its index in the video (`N.txt`, in the clip or in `labels/`); or a visibility list,
  `visible.yaml` in the clip, or the one this package ships for a clip of that name (config/visible_NAME.yaml,
  written by eye from the footage's README, never the footage itself):
      visible: 0-29, 34-42      # the frames where the ball is in view (index from 0); every other frame has none
      ends_in: home_goal        # optional: the last frame with the ball shows it in that goal mouth

Scores (issue 25): a labelled frame is found when the tracker's own image detection (forward or backward pass, never a
Kalman prediction) lies within one ball diameter of the label's centre; the diameter is the median width of the
clip's label boxes; a detection is false when it lies more than two diameters from the label, or in a frame with no
ball label. Median and p95 error (px) are over the detections within two diameters of a label. A frame without a
label file is not scored. A visibility list has no positions: found is a detection in a visible frame, false a
detection in any other, and no error is measured (`-`).

Throughput (`fps`: decoding and tracking; `dec fps`: decoding alone, in the same run) is frames per CPU second of this
process, so that other jobs on a shared machine do not count; run it on one core (`taskset -c 0`) for the target.
"""
from __future__ import annotations

import math
import re
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Iterator, Optional

import cv2
import numpy as np
import yaml

from foos_core.table_geometry import TableGeometry

from .camera.field_corners import field_reference
from .detection.ball_verifier import BallVerifier
from .detection.still_ball import StillBallFinder, _pick, _verified_pick, verify
from .errors import VisionError
from .tracking.backfill import OfflineTracker
from .tracking.tracker import BallTracker, TrackerConfig, choose_colour
from .video_io import VideoReader

VIDEO_SUFFIXES = (".mp4", ".avi", ".mkv", ".mov", ".m4v", ".webm")
IMAGE_SUFFIXES = (".jpg", ".jpeg", ".png", ".bmp")
SHIPPED_LABELS = Path(__file__).resolve().parent / "config"  # visible_NAME.yaml: a clip NAME's visibility list
DEFAULT_FPS = 30.0  # frames in a folder carry no rate; a sequence of them is timed at this
BALL_CLASS = 0


@dataclass
class Clip:
    name: str
    folder: Path
    video: Optional[Path] = None
    frames: list[Path] = field(default_factory=list)
    markers: Optional[Path] = None
    corners: Optional[str] = None
    labels: Optional[dict[int, list[tuple[float, float, float]]]] = None  # frame -> ball (cx, cy, w) in px
    visible: Optional[set[int]] = None
    ends_in: Optional[str] = None
    labels_from: str = ""

    @property
    def stills(self) -> bool:
        return self.video is None and self.markers is None and self.corners is None


@dataclass
class ClipResult:
    clip: str
    mode: str
    frames: int
    scored: int  # labelled frames with the ball (or visible frames)
    found: int
    detections: int
    false: int
    errors: list[float]
    fps_track: float = float("nan")  # decoding included
    fps_decode: float = float("nan")
    notes: list[str] = field(default_factory=list)

    @property
    def recall(self) -> float:
        return self.found / self.scored if self.scored else float("nan")

    @property
    def false_share(self) -> float:
        return self.false / self.detections if self.detections else 0.0


# --- reading a clip ------------------------------------------------------------------------------------------------
def find_clips(root: Path) -> list[Clip]:
    """The clips in root (root itself when it holds footage), each checked for what it needs."""
    root = Path(root)
    if not root.exists():
        raise VisionError(f"--real {root}: no such folder")
    if root.is_file():
        raise VisionError(f"--real {root}: give the clip's folder (its footage, labels and markers), not a file")
    if any(_footage(root)) or any(root.glob("*.txt")):
        return [read_clip(root)]
    folders = sorted(p for p in root.iterdir() if p.is_dir() and not p.name.startswith("."))
    clips = [read_clip(p) for p in folders if any(_footage(p)) or any(p.glob("*.txt"))]
    if not clips:
        raise VisionError(f"--real {root}: no video and no frames ({', '.join(IMAGE_SUFFIXES)}) in it or its sub-folders")
    return clips


def _footage(folder: Path) -> tuple[list[Path], list[Path]]:
    files = sorted(p for p in folder.iterdir() if p.is_file())
    videos = [p for p in files if p.suffix.lower() in VIDEO_SUFFIXES]
    frames = [p for p in files if p.suffix.lower() in IMAGE_SUFFIXES]
    return videos, sorted(frames, key=_frame_number)


def _frame_number(path: Path) -> tuple[int, str]:
    numbers = re.findall(r"\d+", path.stem)
    return (int(numbers[-1]) if numbers else -1, path.name)


def read_clip(folder: Path) -> Clip:
    videos, frames = _footage(folder)
    clip = Clip(folder.name, folder)
    if len(videos) > 1:
        raise VisionError(f"{folder}: {len(videos)} videos in one clip folder; give each its own folder")
    if videos:
        clip.video = videos[0]
    elif frames:
        clip.frames = frames
    else:
        raise VisionError(f"{folder}: labels but no frames and no video to score them on")
    for path in sorted(folder.glob("*.y*ml")):
        if path.name.startswith("visible"):
            continue
        with open(path) as f:
            try:
                content = yaml.safe_load(f)
            except yaml.YAMLError:
                continue
        if isinstance(content, dict) and "markers" in content:
            clip.markers = path
    corners = folder / "field_corners.txt"
    if corners.exists():
        clip.corners = corners.read_text().strip()
    _read_truth(clip)
    return clip


def _read_truth(clip: Clip) -> None:
    label_dir = clip.folder / "labels" if (clip.folder / "labels").is_dir() else clip.folder
    label_files = sorted(p for p in label_dir.glob("*.txt") if p.name != "field_corners.txt")
    if label_files:
        if clip.frames:
            by_stem = {p.stem: k for k, p in enumerate(clip.frames)}
            keyed = {by_stem[p.stem]: p for p in label_files if p.stem in by_stem}
            if not keyed:
                raise VisionError(f"{label_dir}: no label file is named after a frame of the clip")
        else:
            keyed = {_frame_number(p)[0]: p for p in label_files if _frame_number(p)[0] >= 0}
            if not keyed:
                raise VisionError(f"{label_dir}: label files must be named by the frame's index (N.txt)")
        size = _image_size(clip)
        clip.labels = {k: read_yolo(p, size) for k, p in sorted(keyed.items())}
        clip.labels_from = f"YOLO labels ({len(keyed)} files)"
        return
    listed = clip.folder / "visible.yaml"
    shipped = SHIPPED_LABELS / f"visible_{clip.name}.yaml"
    source = listed if listed.exists() else shipped if shipped.exists() else None
    if source is None:
        raise VisionError(f"{clip.folder}: no labels (YOLO .txt per frame) and no visibility list (visible.yaml)")
    clip.visible, clip.ends_in = read_visibility(source)
    clip.labels_from = f"visibility list {source.name}" + (" (shipped)" if source == shipped else "")


def _image_size(clip: Clip) -> tuple[int, int]:
    if clip.frames:
        image = cv2.imread(str(clip.frames[0]))
        if image is None:
            raise VisionError(f"{clip.frames[0]}: not an image OpenCV can read")
        return image.shape[1], image.shape[0]
    reader = VideoReader(str(clip.video))
    try:
        if reader.width <= 0 or reader.height <= 0:
            raise VisionError(f"{clip.video}: the video does not say its size")
        return reader.width, reader.height
    finally:
        reader.close()


def read_yolo(path: Path, size: tuple[int, int]) -> list[tuple[float, float, float]]:
    """The ball boxes of a YOLO label file as (cx, cy, w) in pixels; VisionError on any line that is not
    `class cx cy w h` with the four normalised to the image."""
    balls = []
    for number, line in enumerate(path.read_text().splitlines(), start=1):
        if not line.strip():
            continue
        parts = line.split()
        try:
            values = [float(x) for x in parts]
        except ValueError:
            values = []
        if (len(values) != 5 or values[0] != int(values[0]) or values[0] < 0
                or not all(0.0 <= x <= 1.0 for x in values[1:])):
            raise VisionError(f"{path}:{number}: not a YOLO label (`class cx cy w h`, the four in 0-1): `{line.strip()}`")
        if int(values[0]) == BALL_CLASS:
            balls.append((values[1] * size[0], values[2] * size[1], values[3] * size[0]))
    return balls


def read_visibility(path: Path) -> tuple[set[int], Optional[str]]:
    with open(path) as f:
        try:
            content = yaml.safe_load(f)
        except yaml.YAMLError as error:
            raise VisionError(f"{path}: not YAML ({str(error).splitlines()[0]})") from None
    if not isinstance(content, dict) or "visible" not in content:
        raise VisionError(f"{path}: a visibility list needs `visible: A-B, C, ...` (frame indices from 0)")
    visible: set[int] = set()
    for part in str(content["visible"]).replace("[", "").replace("]", "").split(","):
        match = re.fullmatch(r"\s*(\d+)\s*(?:-\s*(\d+))?\s*", part)
        if match is None:
            raise VisionError(f"{path}: `{part.strip()}` is not a frame index or a range A-B")
        first = int(match.group(1))
        visible.update(range(first, int(match.group(2) or first) + 1))
    ends_in = content.get("ends_in")
    if ends_in not in (None, "home_goal", "away_goal"):
        raise VisionError(f"{path}: ends_in must be home_goal or away_goal, not `{ends_in}`")
    return visible, ends_in


# --- running the tracker -------------------------------------------------------------------------------------------
def _frames_of(clip: Clip, fps: float) -> Iterator[tuple[int, float, np.ndarray]]:
    if clip.video is not None:
        reader = VideoReader(str(clip.video))
        try:
            yield from reader.frames()
        finally:
            reader.close()
        return
    for k, path in enumerate(clip.frames):
        image = cv2.imread(str(path))
        if image is None:
            raise VisionError(f"{path}: not an image OpenCV can read")
        yield k, k / fps, image


def _clip_fps(clip: Clip) -> float:
    if clip.video is None:
        return DEFAULT_FPS
    reader = VideoReader(str(clip.video))
    reader.close()
    return reader.fps


def track_clip(clip: Clip, params_file: Optional[str] = None) -> tuple[dict[int, tuple[float, float]], dict]:
    """Per frame index, the tracker's image detection (u, v), as track_video finds it with the default options;
    and what else the run tells (throughput, the last detection's table position)."""
    fps = _clip_fps(clip)
    layout = field_reference(str(clip.markers) if clip.markers else None, clip.corners,
                             names=("markers file", "field_corners.txt"))
    config = TrackerConfig(params_file=params_file)
    started = time.process_time()
    decoded = sum(1 for _ in _frames_of(clip, fps))
    decode_time = time.process_time() - started
    probe = (frame for index, _, frame in _frames_of(clip, fps) if index < 10 * fps)
    config.ball_color = choose_colour(probe, layout, config, fps) or "auto"
    tracker = BallTracker(layout, config)
    offline = OfflineTracker(tracker, fps)
    started = time.process_time()
    for index, t, frame in _frames_of(clip, fps):
        offline.process(index, t, frame)
    offline.finish()
    track_time = time.process_time() - started
    results = offline.results()
    info = {"fps_track": decoded / track_time, "fps_decode": decoded / decode_time, "frames": decoded,
            "colour": tracker.colour.name}
    if results:
        last = results[-1]
        info["last"] = (last.index, last.detection.x, last.detection.y)
    return {r.index: (r.detection.u, r.detection.v) for r in results}, info


def find_stills(clip: Clip, params_file: Optional[str] = None, verifier: Optional[BallVerifier] = None,
                keep_candidates: bool = False) -> tuple[dict[int, tuple[float, float]], dict]:
    """Per frame, the ball StillBallFinder reports in that frame alone (its best candidate, if clear enough), or none.
    With a verifier, info["verified"] holds the same with the verifier's pick (still_ball._verified_pick), from the
    same candidates, and info["fps_verified"] the rate with the verifier's scoring counted. keep_candidates:
    info["candidates"] holds each frame's candidates, best first (for per_frame_lines)."""
    finder = StillBallFinder(params_file)
    found: dict[int, tuple[float, float]] = {}
    verified: dict[int, tuple[float, float]] = {}
    kept: dict[int, list] = {}
    no_field = frames = 0
    verifying = 0.0
    started_all = time.process_time()
    for k, _, image in _frames_of(clip, DEFAULT_FPS):
        field_, candidates = finder.find(image)
        ball = _pick(candidates, field_)
        if keep_candidates:
            kept[k] = candidates
        frames += 1
        no_field += field_ is None
        if ball is not None:
            found[k] = (ball.u, ball.v)
        if verifier is not None and field_ is not None:
            started = time.process_time()
            verify(verifier, image, field_, candidates)
            ball = _verified_pick(candidates, field_)
            verifying += time.process_time() - started
            if ball is not None:
                verified[k] = (ball.u, ball.v)
    finding = time.process_time() - started_all - verifying  # decoding included, as for a tracked clip
    info = {"fps_track": frames / finding, "frames": frames, "no_field": no_field, "candidates": kept}
    if verifier is not None:
        info.update(verified=verified, fps_verified=frames / (finding + verifying),
                    verifier_ms=1000 * verifying / max(frames, 1))
    return found, info


# --- scoring -------------------------------------------------------------------------------------------------------
def judge_frame(balls: list, seen: Optional[tuple[float, float]],
                diameter: float) -> tuple[str, Optional[float], Optional[tuple[float, float]]]:
    """One labelled frame's verdict, the one rule of score and per_frame_lines: `found` (the pick within one diameter
    of the nearest label), `near` (within two: neither found nor false), `wrong` (farther, or a pick in a frame with no
    ball), `missed` (no pick with a ball labelled), `none` (no pick, no ball); with the pick's distance (px) and the
    label's centre it is judged against (the nearest, or the first where there is no pick)."""
    if not balls:
        return ("wrong" if seen is not None else "none"), None, None
    if seen is None:
        return "missed", None, (balls[0][0], balls[0][1])
    cx, cy, _ = min(balls, key=lambda b: math.hypot(seen[0] - b[0], seen[1] - b[1]))
    error = math.hypot(seen[0] - cx, seen[1] - cy)
    verdict = "found" if error <= diameter else "near" if error <= 2 * diameter else "wrong"
    return verdict, error, (cx, cy)


def score(clip: Clip, detections: dict[int, tuple[float, float]], frames: int, mode: str) -> ClipResult:
    if clip.labels is not None:
        widths = [w for balls in clip.labels.values() for _, _, w in balls]
        if not widths:
            raise VisionError(f"{clip.folder}: the labels have no ball (class {BALL_CLASS}) box to size the ball by")
        diameter = float(np.median(widths))
        scored = found = false = counted = 0
        errors = []
        for k, balls in clip.labels.items():
            seen = detections.get(k)
            scored += bool(balls)
            counted += seen is not None
            verdict, error, _ = judge_frame(balls, seen, diameter)
            found += verdict == "found"
            false += verdict == "wrong"
            if verdict in ("found", "near"):
                errors.append(error)
        result = ClipResult(clip.name, mode, frames, scored, found, counted, false, errors)
        result.notes.append(f"ball diameter {diameter:.1f} px (median label width)")
        return result
    assert clip.visible is not None
    in_view = [k for k in range(frames) if k in clip.visible]
    found = sum(1 for k in in_view if k in detections)
    false = sum(1 for k in detections if k not in clip.visible)
    return ClipResult(clip.name, mode, frames, len(in_view), found, len(detections), false, [])


def per_frame_lines(clip: Clip, detections: dict[int, tuple[float, float]], frames: int,
                    candidates: Optional[dict[int, list]] = None) -> list[str]:
    """One line per scored frame, judged as score judges it (judge_frame); the label's centre, the pick and its distance (px); and where
    the pick is not `found`, the ball's best candidate (the best-scored within one diameter of the label: its rank
    among the frame's candidates from 1, its cue and its score), or `no candidate` within a diameter. A visibility
    list has no positions: a frame is then found, missed, wrong or none by the list alone."""
    def name(k: int) -> str:
        return clip.frames[k].name if clip.frames and k < len(clip.frames) else f"frame {k}"

    lines = []
    if clip.labels is None:
        assert clip.visible is not None
        for k in range(frames):
            seen, visible = detections.get(k), k in clip.visible
            verdict = ("found" if seen else "missed") if visible else ("wrong" if seen else "none")
            pick = f" pick ({seen[0]:.0f}, {seen[1]:.0f})" if seen else ""
            lines.append(f"{name(k)}: {verdict}{' (in view)' if visible else ''}{pick}")
        return lines
    diameter = float(np.median([w for balls in clip.labels.values() for _, _, w in balls] or [float("nan")]))
    for k, balls in clip.labels.items():
        seen = detections.get(k)
        pick = f"; pick ({seen[0]:.0f}, {seen[1]:.0f})" if seen else "; no pick"
        verdict, error, label = judge_frame(balls, seen, diameter)
        if label is None:
            lines.append(f"{name(k)}: {verdict}: no ball labelled{pick}")
            continue
        cx, cy = label
        if error is not None:
            pick += f" {error:.1f} px off"
        line = f"{name(k)}: {verdict}: label ({cx:.0f}, {cy:.0f}){pick}"
        if verdict != "found" and candidates is not None:
            ranked = [(rank, c) for rank, c in enumerate(candidates.get(k, []), start=1)
                      if math.hypot(c.u - cx, c.v - cy) <= diameter]
            if ranked:
                rank, best = ranked[0]
                line += f"; ball's best candidate: rank {rank}, {best.cue}, score {best.score:.2f}"
            else:
                line += "; ball's best candidate: no candidate within a diameter"
        lines.append(line)
    return lines


def goal_mouth_note(clip: Clip, info: dict, params_file: Optional[str]) -> Optional[str]:
    """Whether the track's last detection lies in the goal mouth the visibility list names."""
    if clip.ends_in is None:
        return None
    if "last" not in info:
        return f"ends in {clip.ends_in}: no detection at all"
    table = TableGeometry.of(params_file)
    index, x, y = info["last"]
    sign = -1.0 if clip.ends_in == "home_goal" else 1.0
    # In the mouth: across it within the goal's width, and within a ball's width of the goal line (either side).
    inside = abs(x) <= table.goal_half_width and abs(y - sign * table.half_length) <= 2 * table.ball_radius
    return (f"track ends at frame {index}, ({1000 * x:.0f}, {1000 * y:.0f}) mm: "
            f"{'in' if inside else 'NOT in'} the {clip.ends_in.replace('_', ' ')} mouth")


def run_real(root: Path, params_file: Optional[str] = None, echo=print, as_stills: bool = False,
             verifier: Optional[BallVerifier] = None, per_frame: bool = False) -> list[ClipResult]:
    """A row per clip. as_stills: every clip's frames scored one by one as single stills (the field found in each,
    no tags, corners or time order), a video or a clip with markers too. verifier: stills are scored twice in the same
    run, without it and with it (a second row, "+verifier"), on the same candidates. per_frame: under each stills
    row, a line per scored frame (per_frame_lines)."""
    cv2.setNumThreads(1)
    clips = find_clips(root)
    echo(REAL_HEADER)
    results = []
    for clip in clips:
        rows = []
        if clip.stills or as_stills:
            detections, info = find_stills(clip, params_file, verifier, keep_candidates=per_frame)
            rows.append(("stills, field found", detections, info["fps_track"]))
            if verifier is not None:
                rows.append(("stills, +verifier", info["verified"], info["fps_verified"]))
        else:
            detections, info = track_clip(clip, params_file)
            mode = "video" if clip.video is not None else "frames"
            rows.append((mode + (", tags" if clip.markers else ", corners"), detections, info["fps_track"]))
        for mode, found, fps in rows:
            result = score(clip, found, info["frames"], mode)
            result.fps_track = fps
            result.fps_decode = info.get("fps_decode", float("nan"))
            result.notes.insert(0, clip.labels_from)
            if info.get("no_field"):
                result.notes.append(f"no field found in {info['no_field']} frames")
            if "colour" in info:
                result.notes.append(f"colour {info['colour']}")
            if mode.endswith("verifier"):
                result.notes.append(f"verifier {info['verifier_ms']:.1f} ms of CPU a frame")
            # Stills have no track to end anywhere.
            note = None if mode.startswith("stills") else goal_mouth_note(clip, info, params_file)
            if note:
                result.notes.append(note)
            results.append(result)
            echo(format_real_row(result))
            echo(f"  {clip.name}: " + "; ".join(result.notes))
            if per_frame and mode.startswith("stills"):
                for line in per_frame_lines(clip, found, info["frames"], info["candidates"]):
                    echo(f"    {line}")
    return results


REAL_HEADER = (f"{'clip':<18} {'mode':<22} {'frames':>6} {'ball':>5} {'found':>5} {'recall%':>7} {'med px':>6} "
               f"{'p95 px':>6} {'dets':>5} {'false':>5} {'false%':>6} {'fps':>6} {'dec fps':>7}")


def format_real_row(r: ClipResult) -> str:
    med = f"{np.median(r.errors):6.1f}" if r.errors else f"{'-':>6}"
    p95 = f"{np.percentile(r.errors, 95):6.1f}" if r.errors else f"{'-':>6}"
    return (f"{r.clip:<18} {r.mode:<22} {r.frames:>6} {r.scored:>5} {r.found:>5} {100 * r.recall:>7.1f} {med} {p95} "
            f"{r.detections:>5} {r.false:>5} {100 * r.false_share:>6.1f} {r.fps_track:>6.0f} {r.fps_decode:>7.0f}")


def run_cli_body(body) -> None:
    """bench_vision's way with bad input: one line on stderr and exit status 2."""
    try:
        body()
    except (VisionError, ValueError, OSError) as error:
        text = str(error).strip().splitlines()
        print(f"bench_vision: error: {text[0] if text else type(error).__name__}", file=sys.stderr)
        sys.exit(2)
