"""Accuracy and throughput of the tracker on rendered videos with known truth (scripts/bench_vision).

Each case renders a rollout (rods kicking, random rolls, the ball picked up now and then), tracks it
with the same code as track_video (the offline path: forward tracking plus a backward pass before each
new track), and compares with the truth frame by frame:
- position error (mm) of every detection of a frame where the ball is in view on the table,
- recall over frames where at least half the ball is visible (on the table): `recall%` for the offline
  path (track_video), `onl%` for the forward pass alone (what tracker_node publishes live); `half` and
  `hid` count the half-visible and the hidden frames the two rates are taken over,
- frames where the ball flies (centre > 5 mm above rest; `air`), left out of the two above,
- false detections per 1000 frames where the ball is hidden entirely,
- speed error (m/s, median) of central differences and of the Kalman filter,
- tracker throughput on one core (frames/s; decoding excluded, and included).

The fisheye case (the issue's real clip as near as the renderer comes: 1080p, 25 fps, a yellow ball) is
tracked with the lens render_video used, and again (`+calib` row) with the intrinsics that
`calibrate_camera --fisheye` finds on checkerboard views drawn through that lens (foos_sim.camera.boards).

The hands case (`overhead-640-60-orange-hands`) is picked up by a rendered hand and forearm (render_video
--hands) instead of vanishing: a skin-coloured blob over the field that the tracker is not told about.

With `--figure-mask both` (the default) every case is tracked twice: as now, and with the figure mask
(`+mask` rows), fed the rendered rod joint positions (OUT.joints.csv) as track_video's --joint-states
or tracker_node's /joint_states would be.

`--shots` runs the shot cases instead (SHOT_CASES): shots at 3-8 m/s toward a goal past rods that hang, lift or lie
level (foos_sim.camera.shots, filmed by render_video --bag), at 25, 30 and 60 fps with a camera's exposure (half the
frame interval to all of it, 8-16 sub-frames), so that the ball is a streak several of its widths long. Their `fast`
columns count the frames where the ball, at least half in view on the table, moves at FAST_SPEED or more (`fast`),
the share of those with a detection (`fast%`, offline), and the 95th percentile of their errors (`fp95`). A frame in
whose exposure the ball was hit (a figure, a wall: its direction turned by HIT_TURN or more, from the shots' own
states) is counted apart (`hits`, and their recall `hit%`): its streak is bent, and its centre is not measured.

`--throughput` times track_video's offline path on one core, decoding included, next to decoding alone in the same
run (foos_vision.throughput): the real video clips of --real DIR (default ../shared/realdata) and the 1280x720 render
THROUGHPUT_CASE, --repeats times each, medians and their ratio.

Every case's game is played on the 20 kHz reference physics (params/reference_table.yaml), where the cases were
chosen: the videos, and so the numbers in docs/measurements, stay those measured since 21 Nov now that the
simulation's default is the fast physics, whose games with the same seeds play out differently.
"""
from __future__ import annotations

import argparse
import math
import shutil
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from foos_bag import read_ball_states
from foos_core.camera_model import load_camera, load_intrinsics
from foos_core.markers import load_markers
from foos_core.table_params import REFERENCE_PARAMS_FILE
from foos_sim.camera.boards import board_views
from foos_sim.camera.render import read_joints, read_truth

from .camera.field_corners import field_reference
from .camera.figure_mask import FigureGeometry, joint_track
from .detection.ball_verifier import BallVerifier
from .field_bench import run_field_auto
from .real_bench import find_clips, run_cli_body, run_real
from .still_renders import run_still_renders
from .throughput import REPEATS, run_throughput
from .tracking.backfill import OfflineTracker
from .tracking.tracker import BallTracker, TrackerConfig, choose_colour
from .tracking.velocity import central_differences
from .video_io import VideoReader

AIRBORNE_Z = 0.0225  # m: ball centre more than 5 mm above its resting height
FAST_SPEED = 1.5  # m/s: a ball this fast moves more than its width in half a 25 fps frame: a streak
HIT_TURN, HIT_SPEED = math.radians(20.0), 0.5  # a hit turns a ball going HIT_SPEED or faster by HIT_TURN or more
TARGETS = {"median_mm": 2.0, "p95_mm": 5.0, "recall": 0.98, "false_per_1000": 1.0}
THROUGHPUT_TARGETS = {(640, 480): 200.0, (1280, 720): 60.0}


@dataclass(frozen=True)
class Case:
    name: str
    camera: str
    width: int
    height: int
    fps: float
    colour: str
    blur: int = 1
    distortion: tuple = ()
    lighting: float = 1.0
    fisheye: bool = False  # the camera config is a fisheye: tracked with its intrinsics, and (+calib row) with
    # the intrinsics calibrate_camera --fisheye finds on checkerboards drawn through the same lens
    hands: bool = False  # a player's hand picks the ball up (render_video --hands); the tracker is not told
    home: str = ""  # the figures' colours (render_video --home-color/--away-color); "": foos_sim's red and blue
    away: str = ""
    exposure: float = 0.5  # the shutter's share of the frame interval (render_video --exposure; with blur > 1)
    shots: bool = False  # shots (foos_sim.camera.shots) instead of the play scenario
    length: float = 1.0  # the case's video is this many times --duration


CASES = (
    Case("overhead-640-120-white", "overhead", 640, 480, 120, "white"),
    Case("overhead-1280-60-yellow", "overhead", 1280, 720, 60, "yellow", lighting=0.8),
    Case("oblique-640-60-orange", "oblique", 640, 480, 60, "orange"),
    Case("oblique-1280-120-yellow", "oblique", 1280, 720, 120, "yellow", lighting=1.2),
    Case("overhead-640-120-red-lens", "overhead", 640, 480, 120, "red", distortion=(-0.28, 0.09)),
    Case("overhead-640-60-white-blur", "overhead", 640, 480, 60, "white", blur=4),
    # The issue's real clip, as near as the renderer comes: 1080p, 25 fps, fisheye, yellow ball, the blur a
    # 25 fps shutter gives (half the frame interval, 4 sub-frames). Hands are the next case's.
    Case("overhead-1920x1080-25-yellow-fisheye", "fisheye", 1920, 1080, 25, "yellow", blur=4, fisheye=True),
    # A skin-coloured hand and forearm reach in, cover the ball while it is picked up, and leave: orange is the
    # ball colour nearest skin. (Last in the list, so the other cases keep their seeds.)
    Case("overhead-640-60-orange-hands", "overhead", 640, 480, 60, "orange", hands=True),
)
# Shots past figures, the ball a streak (foos_sim.camera.shots): the issue's 25 fps with a shutter open all of the frame
# interval and half of it, 30 fps, and 60 fps; figures of the ball's colour in two; twice as long as the others, since
# a shot is over in a few frames.
SHOT_CASES = (
    Case("shots-1280-25-yellow-exp1.0", "overhead", 1280, 720, 25, "yellow", blur=12, exposure=1.0, shots=True,
         length=2.0),
    Case("shots-1280-25-yellow-same-exp0.5", "overhead", 1280, 720, 25, "yellow", blur=8, exposure=0.5, shots=True,
         length=2.0, home="yellow"),
    Case("shots-640-30-orange-exp0.5", "overhead", 640, 480, 30, "orange", blur=8, exposure=0.5, shots=True,
         length=2.0),
    Case("shots-640-60-yellow-same-exp0.8", "overhead", 640, 480, 60, "yellow", blur=8, exposure=0.8, shots=True,
         length=2.0, away="yellow"),
)
CALIBRATION_VIEWS = 16  # checkerboard views for the +calib row (9x6 inner corners, 30 mm squares)


def render_case(case: Case, out: Path, duration: float, seed: int, reuse: bool = False) -> Path:
    video = out / f"{case.name}.mp4"
    duration *= case.length
    command = [sys.executable, "-m", "foos_sim.camera.render_cli", str(video), "--camera", case.camera,
               "--width", str(case.width), "--height", str(case.height), "--fps", str(case.fps),
               "--ball-color", case.colour, "--blur", str(case.blur), "--lighting", str(case.lighting),
               "--exposure", str(case.exposure), "--duration", str(duration), "--seed", str(seed),
               "--visibility", "--overwrite", "--quiet", "--params-file", str(REFERENCE_PARAMS_FILE)]
    if case.shots:
        command += ["--bag", str(out / f"{case.name}.shots")]
    else:
        command += ["--hide-every", "1.0", "--hide-for", "0.3"]
    if case.distortion:
        command += ["--distortion=" + ",".join(str(v) for v in case.distortion)]
    if case.hands:
        command += ["--hands"]
    command += [f"--{team}-color={colour}" for team, colour in (("home", case.home), ("away", case.away)) if colour]
    if reuse and video.exists() and Path(f"{out / case.name}.truth.csv").exists() \
            and Path(f"{out / case.name}.joints.csv").exists():
        return video
    if case.shots:
        shutil.rmtree(out / f"{case.name}.shots", ignore_errors=True)
        subprocess.run([sys.executable, "-m", "foos_sim.camera.shots", str(out / f"{case.name}.shots"), "--duration",
                        str(duration), "--seed", str(seed), "--params-file", str(REFERENCE_PARAMS_FILE)],
                       check=True, stdout=subprocess.DEVNULL)
    subprocess.run(command, check=True, stdout=subprocess.DEVNULL)
    return video


def calibrated_intrinsics(case: Case, workdir: Path, seed: int):
    """The intrinsics `calibrate_camera --fisheye` finds on checkerboard views drawn through the case's lens."""
    camera = load_camera(case.camera).with_(width=case.width, height=case.height)
    boards = workdir / f"{case.name}.boards"
    boards.mkdir(exist_ok=True)
    for i, image in enumerate(board_views(camera, CALIBRATION_VIEWS, board=(9, 6), square=0.03, seed=seed)):
        cv2.imwrite(str(boards / f"view{i:02d}.png"), image)
    out = workdir / f"{case.name}.calibrated.yaml"
    subprocess.run([sys.executable, "-m", "foos_vision.calibrate_camera", str(boards), "--board", "9x6",
                    "--square", "0.03", "--fisheye", "--out", str(out)], check=True, stdout=subprocess.DEVNULL)
    return load_intrinsics(out)


def evaluate(video: Path, case: Case, figure_mask: bool = False, intrinsics=None, label: str = "") -> dict:
    stem = video.with_suffix("")
    truth = read_truth(f"{stem}.truth.csv")
    if intrinsics is None and (case.distortion or case.fisheye):
        # The camera file render_video wrote: its `intrinsics:` block is the lens the video was made with.
        intrinsics = load_intrinsics(f"{stem}.camera.yaml")
    layout = load_markers(f"{stem}.markers.yaml")
    reader = VideoReader(str(video))
    frames = [frame for _, _, frame in reader.frames()]
    reader.close()
    figures, joints = None, None
    if figure_mask:
        joints_file = Path(f"{stem}.joints.csv")
        if not joints_file.exists():
            raise SystemExit(f"bench_vision: error: {joints_file} is missing (rendered before joints were written; "
                             f"render again without --reuse)")
        t_j, names, position = read_joints(joints_file)
        joints = joint_track(t_j, names, position, str(joints_file))
        figures = FigureGeometry()
    fps = reader.fps

    def joints_at(t: float):
        return None if joints is None else joints.at(t)

    colour = choose_colour(frames, layout, TrackerConfig(intrinsics=intrinsics), fps, figures, joints_at) or "auto"
    tracker = BallTracker(layout, TrackerConfig(ball_color=colour, intrinsics=intrinsics), figures)
    decode_start = time.perf_counter()
    reader = VideoReader(str(video))
    for _ in reader.frames():
        pass
    reader.close()
    decode_time = time.perf_counter() - decode_start
    offline = OfflineTracker(tracker, reader.fps)
    online = set()
    start = time.perf_counter()
    for k, frame in enumerate(frames):
        if offline.process(k, k / reader.fps, frame, joints_at(k / reader.fps)) is not None:
            online.add(k)
    offline.finish()
    track_time = time.perf_counter() - start
    detections = {r.index: r.detection for r in offline.results()}
    kalman_v = {r.index: r.state[2:4] for r in offline.results()}
    n = len(frames)
    visible = np.nan_to_num(truth["visible"][:n], nan=0.0)
    in_view = ~np.isnan(truth["x"][:n]) & (visible > 0)
    # A kicked ball flies: one camera cannot see its height, so it is reported on the ball plane and
    # its error is parallax, not tracking. Those frames are counted apart.
    on_table = np.nan_to_num(truth["z"][:n], nan=0.0) <= AIRBORNE_Z
    errors = np.array([math.hypot(d.x - truth["x"][k], d.y - truth["y"][k]) * 1000 for k, d in detections.items()
                       if in_view[k] and on_table[k]])
    half = np.nonzero((visible >= 0.5) & on_table)[0]
    speed = np.hypot(np.nan_to_num(truth["vx"][:n]), np.nan_to_num(truth["vy"][:n]))
    hit = hit_during_exposure(f"{stem}.shots", n, fps, case.exposure) if case.shots else np.zeros(n, bool)
    streaks = (visible >= 0.5) & on_table & (speed >= FAST_SPEED)
    fast, hits = np.nonzero(streaks & ~hit)[0], np.nonzero(streaks & hit)[0]
    fast_errors = np.array([math.hypot(detections[k].x - truth["x"][k], detections[k].y - truth["y"][k]) * 1000
                            for k in fast if k in detections])
    hidden = np.nonzero(visible <= 0.0)[0]
    recall = float(np.mean([k in detections for k in half])) if len(half) else math.nan
    online_recall = float(np.mean([k in online for k in half])) if len(half) else math.nan
    false = sum(k in detections for k in hidden)
    keys = sorted(detections)
    t = np.array([detections[k].t for k in keys])
    xy = np.array([[detections[k].x, detections[k].y] for k in keys])
    v_true = np.array([[truth["vx"][k], truth["vy"][k]] for k in keys])
    good = ~np.isnan(v_true[:, 0]) if len(keys) else np.zeros(0, bool)
    v_cd = central_differences(t, xy) if len(keys) else np.zeros((0, 2))
    v_kf = np.array([kalman_v[k] for k in keys]) if keys else np.zeros((0, 2))

    def speed_error(v):
        ok = good & ~np.isnan(v[:, 0])
        return float(np.median(np.linalg.norm(v[ok] - v_true[ok], axis=1))) if np.any(ok) else math.nan

    return {
        "case": case.name + ("+mask" if figure_mask else "") + label, "frames": n, "detections": len(detections),
        "median_mm": float(np.median(errors)) if len(errors) else math.nan,
        "p95_mm": float(np.percentile(errors, 95)) if len(errors) else math.nan,
        "recall": recall, "online_recall": online_recall, "half_visible_frames": len(half),
        "fast_frames": len(fast), "fast_recall": float(np.mean([k in detections for k in fast])) if len(fast) else math.nan,
        "fast_p95_mm": float(np.percentile(fast_errors, 95)) if len(fast_errors) else math.nan,
        "hit_frames": len(hits), "hit_recall": float(np.mean([k in detections for k in hits])) if len(hits) else math.nan,
        "backfilled": offline.backfilled,
        "false_per_1000": 1000.0 * false / len(hidden) if len(hidden) else math.nan, "hidden_frames": len(hidden),
        "speed_err_cd": speed_error(v_cd), "speed_err_kf": speed_error(v_kf),
        "fps_track": n / track_time, "fps_with_decode": n / (track_time + decode_time),
        "size": (case.width, case.height), "colour": tracker.colour.name,
        "airborne_frames": int(np.sum(in_view & ~on_table)), "video_fps": float(fps),
    }


def hit_during_exposure(bag: str, n: int, fps: float, exposure: float) -> np.ndarray:
    """Per frame: the ball was hit while the shutter was open (its direction turned by HIT_TURN or more between two
    states going HIT_SPEED or faster), by the shots' own states (a bag of foos_sim.camera.shots, on the video's clock)."""
    states = read_ball_states(bag)
    velocity = np.asarray(states.velocity)[:, :2]
    moving = np.hypot(*velocity.T) >= HIT_SPEED
    heading = np.arctan2(velocity[:, 1], velocity[:, 0])
    hit = np.zeros(n, bool)
    for k in range(n):
        during = moving & (np.abs(states.t - k / fps) <= exposure / (2 * fps))
        if np.count_nonzero(during) >= 2:
            turn = np.angle(np.exp(1j * (heading[during] - heading[during][0])))
            hit[k] = float(np.ptp(np.unwrap(turn))) >= HIT_TURN
    return hit


def format_row(r: dict) -> str:
    return (f"{r['case']:<42} {r['frames']:>5} {r['half_visible_frames']:>5} {r['hidden_frames']:>5} "
            f"{r['median_mm']:>7.2f} {r['p95_mm']:>7.2f} {100 * r['recall']:>7.1f} {100 * r['online_recall']:>6.1f} "
            f"{r['false_per_1000']:>8.1f} {r['speed_err_cd']:>7.3f} {r['speed_err_kf']:>7.3f} "
            f"{r['fps_track']:>7.0f} {r['fps_with_decode']:>7.0f} {r['airborne_frames']:>5}  {r['colour']:<7}"
            f"{r['fast_frames']:>5} {100 * r['fast_recall']:>6.1f} {r['fast_p95_mm']:>6.2f} {r['hit_frames']:>5} "
            f"{100 * r['hit_recall']:>5.1f}")


HEADER = (f"{'case':<42} {'frames':>5} {'half':>5} {'hid':>5} {'med mm':>7} {'p95 mm':>7} {'recall%':>7} {'onl%':>6} "
          f"{'false/1k':>8} {'|dv|cd':>7} {'|dv|kf':>7} {'fps':>7} {'fps+dec':>7} {'air':>5}  {'colour':<7}"
          f"{'fast':>5} {'fast%':>6} {'fp95':>6} {'hits':>5} {'hit%':>5}")


def run(duration: float, cases: list[Case], workdir: Path, seed: int = 1, echo=print, reuse: bool = False,
        figure_mask: str = "both") -> list[dict]:
    cv2.setNumThreads(1)
    results = []
    echo(HEADER)
    for case in cases:
        # Each case's seed is its place in its whole set, so that `--cases` renders the same scene as a full run.
        case_seed = seed + (SHOT_CASES if case.shots else CASES).index(case)
        video = render_case(case, workdir, duration, case_seed, reuse)
        for masked in {"off": (False,), "on": (True,), "both": (False, True)}[figure_mask]:
            result = evaluate(video, case, masked)
            results.append(result)
            echo(format_row(result))
        if case.fisheye:
            result = evaluate(video, case, False, calibrated_intrinsics(case, workdir, case_seed), "+calib")
            results.append(result)
            echo(format_row(result))
    errors = np.array([[r["median_mm"], r["p95_mm"]] for r in results])
    echo("")
    echo(f"worst case: median {np.nanmax(errors[:, 0]):.2f} mm (target <= {TARGETS['median_mm']}), "
         f"p95 {np.nanmax(errors[:, 1]):.2f} mm (<= {TARGETS['p95_mm']}), "
         f"recall {100 * min(r['recall'] for r in results):.1f} % (>= {100 * TARGETS['recall']:.0f}; "
         f"online {100 * min(r['online_recall'] for r in results):.1f} %), "
         f"false {max(r['false_per_1000'] for r in results):.1f} /1000 (<= {TARGETS['false_per_1000']:g})")
    for size, target in THROUGHPUT_TARGETS.items():
        fps = [r["fps_track"] for r in results if r["size"] == size]
        if fps:
            echo(f"throughput {size[0]}x{size[1]}: median {np.median(fps):.0f} frames/s on one core "
                 f"(target {target:.0f}; ratio {np.median(fps) / target:.2f})")
    for size in sorted({r["size"] for r in results} - set(THROUGHPUT_TARGETS)):
        rows = [r for r in results if r["size"] == size]
        fps = np.median([r["fps_track"] for r in rows])
        rate = max(r["video_fps"] for r in rows)
        echo(f"throughput {size[0]}x{size[1]}: median {fps:.0f} frames/s on one core (no target; "
             f"{fps / rate:.1f} x the video's {rate:g} fps)")
    return results


THROUGHPUT_CASE = "overhead-1280-60-yellow"  # the issue's 1280x720 render


def throughput(args) -> None:
    """bench_vision --throughput: the real video clips (with tags or corners) and the 1280x720 render."""
    clips = []
    real = Path(args.real or "../shared/realdata")
    if real.exists():
        for clip in find_clips(real):
            if clip.video is not None and not clip.stills:
                layout = field_reference(str(clip.markers) if clip.markers else None, clip.corners,
                                         names=("markers file", "field_corners.txt"))
                clips.append((clip.name, clip.video, layout, None))
    else:
        print(f"{real}: absent, no real clip timed (give --real DIR)")
    case = next(c for c in CASES if c.name == THROUGHPUT_CASE)
    with tempfile.TemporaryDirectory(prefix="bench_vision_") as tmp:
        workdir = Path(args.workdir or tmp)
        workdir.mkdir(parents=True, exist_ok=True)
        video = render_case(case, workdir, args.duration, args.seed + CASES.index(case), args.reuse)
        clips.append((case.name, video, load_markers(f"{video.with_suffix('')}.markers.yaml"), None))
        run_throughput(clips, args.repeats, args.params_file)


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="bench_vision", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--duration", type=float, default=4.0, help="seconds of video per case (default 4)")
    p.add_argument("--cases", help="comma-separated case names (default all of the set): "
                   + ", ".join(c.name for c in CASES + SHOT_CASES))
    p.add_argument("--shots", action="store_true", help="the shot cases (the ball a streak) instead of the classic eight")
    p.add_argument("--workdir", help="keep the rendered videos here (default a temporary directory)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--reuse", action="store_true", help="track the videos already in --workdir instead of rendering")
    p.add_argument("--figure-mask", choices=("off", "on", "both"), default="both",
                   help="track without the figure mask from the rendered joint positions, with it (+mask rows), "
                        "or both (default)")
    p.add_argument("--real", metavar="DIR",
                   help="score real footage instead of renders: a clip folder, or a folder of them (see real_bench)")
    p.add_argument("--stills", action="store_true",
                   help="with --real: score every frame alone as a single still (the field found in it, no tags, "
                        "corners or time order), a video or a clip with markers too")
    p.add_argument("--per-frame", action="store_true",
                   help="with --stills: a line per scored frame under the clip's row: found / near / wrong / missed / "
                        "none, the label's centre, the pick and its distance (px), and where the pick is not found the "
                        "ball's best candidate (its rank, cue and score)")
    p.add_argument("--verifier", metavar="WEIGHTS", nargs="?", const="", default=None,
                   help="with --stills or --still-renders: also pick with the ball verifier (a second row, same "
                        "candidates); WEIGHTS: an .npz of its weights (default: the one foos_vision ships)")
    p.add_argument("--still-renders", action="store_true",
                   help="the still finder on 90 single renders of the simulated camera (foos_vision.still_renders)")
    p.add_argument("--field-auto", type=int, metavar="N",
                   help="--field-corners auto against the truth: N random render cases (foos_vision.field_bench), "
                        "from case --field-auto-from")
    p.add_argument("--field-auto-from", type=int, default=0, metavar="SEED", help="the first case's seed (default 0)")
    p.add_argument("--params-file", help="the filmed table's parameter file, for --real (default: the regulation table)")
    p.add_argument("--throughput", action="store_true",
                   help="frames/s on one core, decoding included, next to decoding alone (foos_vision.throughput): the "
                        "real clips of --real DIR (default ../shared/realdata) and THROUGHPUT_CASE rendered in --workdir")
    p.add_argument("--repeats", type=int, default=REPEATS, help=f"runs per clip for --throughput (default {REPEATS})")
    args = p.parse_args(argv)
    if args.throughput:
        run_cli_body(lambda: throughput(args))
        return
    if args.field_auto:
        run_cli_body(lambda: run_field_auto(args.field_auto, args.field_auto_from))
        return
    if args.stills and not args.real:
        p.error("--stills goes with --real DIR")
    if args.per_frame and not args.stills:
        p.error("--per-frame goes with --real DIR --stills")
    if args.verifier is not None and not (args.stills or args.still_renders):
        p.error("--verifier goes with --stills or --still-renders")

    def verifier():
        return None if args.verifier is None else BallVerifier(args.verifier or None)

    if args.still_renders:
        run_cli_body(lambda: run_still_renders(verifier()))
        return
    if args.real:
        run_cli_body(lambda: run_real(Path(args.real), args.params_file, as_stills=args.stills, verifier=verifier(),
                                             per_frame=args.per_frame))
        return
    cases = list(SHOT_CASES if args.shots else CASES)
    if args.cases:
        wanted = args.cases.split(",")
        unknown = set(wanted) - {c.name for c in cases}
        if unknown:
            p.error(f"unknown cases {sorted(unknown)}" + (" (shot cases need --shots)" if not args.shots else ""))
        cases = [c for c in cases if c.name in wanted]
    if args.workdir:
        Path(args.workdir).mkdir(parents=True, exist_ok=True)
        run(args.duration, cases, Path(args.workdir), args.seed, reuse=args.reuse, figure_mask=args.figure_mask)
    else:
        with tempfile.TemporaryDirectory(prefix="bench_vision_") as tmp:
            run(args.duration, cases, Path(tmp), args.seed, figure_mask=args.figure_mask)


if __name__ == "__main__":
    main()
