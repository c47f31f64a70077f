"""`ros2 run foos_calibration twin_video BAG --params-file A.yaml [--params-file B.yaml] --out twin.mp4`: a video of
the measured ball beside each table's simulation, restarted from every measured free stretch (foos_calibration.twin),
filmed by the simulated camera (foos_sim.camera)."""
from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path
from typing import Sequence

import numpy as np

from foos_bag import BagError
from foos_core.camera_model import load_camera
from foos_core.markers import DEFAULT_MARKERS_FILE, load_markers
from foos_core.names import BALL_DETECTION_TOPIC, JOINT_NAMES, JOINT_STATES_TOPIC
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import ParamsError, load_params
from foos_sim.camera.errors import RenderError
from foos_sim.camera.recorded import RecordedStates, read_recorded_states
from foos_sim.camera.render import (
    MEASURED_COLOUR,
    BallMark,
    BallOverlay,
    FrameTruth,
    RenderOptions,
    SceneRenderer,
    write_camera,
    write_video,
)
from foos_sim.camera.scenarios import StateReplay, detections_at
from foos_sim.model_builder import build_mjcf
from foos_sim.simulation import TableSimulation

from .figure_contacts import JointTrack, for_game
from .tracks import DataError, analyse, validate
from .twin import TablePrediction, predict, predicted_at, restarts, restarts_in

os.environ.setdefault("OMP_NUM_THREADS", "1")

NOMINAL = "nominal"  # --params-file nominal: the regulation table (foos_core's parameter file)
TABLE_COLOURS = ((0, 140, 255), (255, 255, 0))  # BGR: orange, then cyan; the measured ball is magenta
TRAIL = 1.0  # s of path drawn behind each ball (a prediction's only back to its restart)

DESCRIPTION = """\
Film the measured ball beside the simulation of one or two tables (say the nominal and the calibrated
one), so a viewer sees where each parts from the measurement.

The measured detections (/ball/detection) are cut into free stretches by calibration's own rule
(tracks, wall contacts, rolling segments). At each stretch, every table's simulation restarts: its ball
state is estimated from the stretch's first 0.3 s of rolling under that table's dynamics, then MuJoCo
rolls it on that table until the next restart on the same track or the end of the track (at most 3 s).
Drawn over the simulated camera (foos_sim.camera): the measured ball (magenta disc), each table's predicted ball
(a ring: orange for the first --params-file, cyan for the second), the path each came along, and a
legend with each prediction's distance to the measured ball. The rods follow /joint_states; a bag
without them (free rolls) is filmed with the rods turned up, figures horizontal.

Writes OUT.mp4, OUT.camera.yaml (the camera, with its OpenCV intrinsics) and OUT.csv: per frame, the
measured and each table's predicted ball centre (m, table frame) and their distance (mm); prints the
median and p95 distances over the frames where every table's ball is drawn.
"""

EPILOG = """\
Example (the demo's):
  ros2 run foos_calibration calibrate out/measured --out out/calibration
  ros2 run foos_calibration twin_video out/measured --params-file nominal \\
      --params-file out/calibration/calibrated_table.yaml --out out/calibration/twin.mp4 --duration 20
Exit status: 0 done, 2 bad input (one line on stderr).
"""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="twin_video", description=DESCRIPTION, epilog=EPILOG,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("bag", help="rosbag2 directory with /ball/detection (and /joint_states where the rods are instrumented)")
    p.add_argument("--params-file", action="append", required=True, metavar="PARAMS",
                   help="a table's parameter file, or `nominal` for the regulation table; give it twice to compare two")
    p.add_argument("--out", required=True, help="output video (.mp4); OUT.camera.yaml and OUT.csv go next to it")
    p.add_argument("--start", type=float, default=0.0, help="seconds after the first detection to start at (default 0)")
    p.add_argument("--duration", type=float, help="seconds of video (default: to the last detection)")
    p.add_argument("--camera", default="overhead", help="overhead, oblique, fisheye or a camera YAML (default overhead)")
    p.add_argument("--width", type=int, default=640)
    p.add_argument("--height", type=int, default=480)
    p.add_argument("--fps", type=float, default=20.0, help="frames per second of video time (default 20)")
    p.add_argument("--fovy", type=float, help="vertical field of view, degrees (default: the camera's; 36 fills the "
                   "overhead view with the field)")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress")
    return p


def table_labels(paths: Sequence[str]) -> list[str]:
    """A short name per table for the legend and the CSV: `nominal`, else the file's stem (numbered if repeated)."""
    stems = [NOMINAL if p == NOMINAL else Path(p).stem for p in paths]
    return [s if stems.count(s) == 1 else f"{s}{i + 1}" for i, s in enumerate(stems)]


def rods_up(recorded: RecordedStates) -> RecordedStates:
    """The recording with its rods turned up (figures horizontal) for its whole length: how free rolls are recorded."""
    pose = np.zeros(len(JOINT_NAMES))
    pose[1::2] = math.pi / 2  # every rotate joint
    return recorded._replace(joint_t=np.array([recorded.start, recorded.end]), joint_position=np.stack([pose, pose]))


def trail_of(prediction: TablePrediction, t: float, geometry: TableGeometry) -> np.ndarray | None:
    """The predicted path (k, 3) over the last TRAIL s before t, back to its restart at most."""
    for tau, xy in zip(prediction.times, prediction.xy):
        if tau[0] <= t <= tau[-1]:
            keep = (tau >= t - TRAIL) & (tau <= t)
            return np.c_[xy[keep], np.full(keep.sum(), geometry.ball_radius)]
    return None


def film(args: argparse.Namespace, progress) -> str:
    out = Path(args.out)
    if out.suffix.lower() != ".mp4":
        raise RenderError(f"{out}: the output must be an .mp4 file")
    outputs = [out, out.with_suffix(".camera.yaml"), out.with_suffix(".csv")]
    existing = [str(o) for o in outputs if o.exists()]
    if existing and not args.overwrite:
        raise RenderError(f"{existing[0]} exists (use --overwrite to replace it)")
    if len(args.params_file) > len(TABLE_COLOURS):
        raise RenderError(f"--params-file is given {len(args.params_file)} times; at most {len(TABLE_COLOURS)} tables are drawn")
    if not (args.fps > 0 and args.start >= 0 and (args.duration is None or args.duration > 0)
            and (args.fovy is None or 0 < args.fovy < 170)):
        raise RenderError("--fps and --duration must be positive, --start at least 0, --fovy between 0 and 170")
    camera = load_camera(args.camera).with_(width=args.width, height=args.height, fps=args.fps, fovy=args.fovy)
    if camera.width % 2 or camera.height % 2 or camera.width < 16 or camera.height < 16:
        raise RenderError("--width and --height must be even (mp4v) and at least 16")
    tables = [load_params(None if path == NOMINAL else path) for path in args.params_file]
    labels = table_labels(args.params_file)
    geometry = TableGeometry.from_params(tables[0])
    if not Path(args.bag).exists():
        raise RenderError(f"bag not found: {args.bag}")
    recorded = read_recorded_states(args.bag)
    if recorded.detection_t is None:
        raise RenderError(f"{args.bag} has no {BALL_DETECTION_TOPIC}: the twin is compared with the measured ball")
    t, xy = validate(recorded.detection_t, recorded.detection_position, "table")
    begin = float(t[0]) + args.start
    end = float(t[-1]) if args.duration is None else min(float(t[-1]), begin + args.duration)
    if end <= begin:
        raise RenderError(f"--start {args.start:g} s is past the recording's last detection ({t[-1] - t[0]:.1f} s)")
    progress("cutting the measurement into free stretches (calibration's tracks and segments)")
    # A game's stretches end at figure contacts, as calibration cuts them: the figures posed from the joint
    # states, or, without them, sudden velocity changes near the rod lines.
    joints = JointTrack(recorded.joint_t, recorded.joint_position) if recorded.joint_t is not None else None
    shown = restarts_in(restarts(analyse(t, xy, geometry, figures=for_game(tables[0], joints))), begin, end)
    predictions = []
    for label, params in zip(labels, tables):
        progress(f"{label}: restarting the simulation at {len(shown)} free stretches (MuJoCo)")
        predictions.append(predict(shown, label, params))

    times = begin + np.arange(int(math.floor((end - begin) * camera.fps)) + 1) / camera.fps
    measured = detections_at(t, np.c_[xy, np.full(len(t), geometry.ball_radius)], times)
    predicted = [np.c_[predicted_at(p, geometry, times), np.full(len(times), geometry.ball_radius)] for p in predictions]
    distance = [np.linalg.norm(p[:, :2] - measured[:, :2], axis=1) for p in predicted]  # NaN where either is not drawn

    if recorded.joint_t is None:
        print(f"twin_video: {args.bag} has no {JOINT_STATES_TOPIC}: the rods are drawn turned up (figures horizontal), "
              "as free rolls are recorded", file=sys.stderr)
        recorded = rods_up(recorded)
    # The scene's own ball stays out of sight: every ball in the video is drawn over it, from the arrays above.
    scene = StateReplay(TableSimulation(params=tables[0]), recorded._replace(t=None, ball_position=None, ball_velocity=None))
    offset = begin - scene.t0
    marks = [BallMark("measured", MEASURED_COLOUR, "disc")]
    marks += [BallMark(label, colour, "ring", ring_gap=3 + 4 * i) for i, (label, colour) in enumerate(zip(labels, TABLE_COLOURS))]
    draw = BallOverlay(camera, marks, geometry.ball_radius)
    measured_trail = np.c_[xy, np.full(len(t), geometry.ball_radius)]

    def overlay(k: int, image: np.ndarray, truth: FrameTruth) -> None:
        now = times[k]
        paths = [trail_of(p, now, geometry) for p in predictions]
        active = [r.start.t0 for r in shown if r.start.t0 <= now <= r.until]
        since = max([now - TRAIL] + active)  # the measured path back to the restart the predictions came from
        seen = measured_trail[(t >= since) & (t <= now)]
        notes = [""] + [f"{d[k] * 1000:.0f} mm" if np.isfinite(d[k]) else "" for d in distance]
        draw(image, [measured[k]] + [p[k] for p in predicted], notes, f"t = {now - t[0]:.2f} s", [seen] + paths)

    options = RenderOptions(camera=camera, noise=0.0, shadows=False)
    renderer = SceneRenderer(build_mjcf(params=tables[0]), load_markers(DEFAULT_MARKERS_FILE), options)
    truths: list[FrameTruth] = []
    try:
        write_video(out, renderer, lambda tv: scene.state_at(tv + offset), len(times), truths, overlay=overlay,
                    quiet=args.quiet, desc="twin_video")
    finally:
        renderer.close()
    write_camera(outputs[1], camera)
    columns = ["frame", "t", "measured_x", "measured_y"]
    rows = [np.arange(len(times)), times - t[0], measured[:, 0], measured[:, 1]]
    for label, p, d in zip(labels, predicted, distance):
        columns += [f"{label}_x", f"{label}_y", f"{label}_distance_mm"]
        rows += [p[:, 0], p[:, 1], d * 1000]
    np.savetxt(outputs[2], np.stack(rows, axis=1), delimiter=",", header=",".join(columns), comments="",
               fmt=["%d", "%.4f"] + ["%.6f"] * 2 + ["%.6f", "%.6f", "%.2f"] * len(labels))
    return summary(out, len(times), camera, len(shown), labels, distance)


def summary(out: Path, frames: int, camera, n_restarts: int, labels: list[str], distance: list[np.ndarray]) -> str:
    every = np.all(np.isfinite(np.stack(distance)), axis=0)  # frames where the measured ball and every table's are drawn
    lines = [f"twin_video: {frames} frames {camera.width}x{camera.height} @ {camera.fps:g} fps -> {out} "
             f"(the simulation restarts at {n_restarts} measured free stretches)"]
    if every.any():
        parts = [f"{label} median {np.median(d[every]) * 1000:.1f} mm (p95 {np.percentile(d[every], 95) * 1000:.1f})"
                 for label, d in zip(labels, distance)]
        lines.append(f"  distance to the measured ball over the {int(every.sum())} frames where every table's ball is drawn: "
                     + ", ".join(parts))
    else:
        lines.append("  no frame shows a prediction beside the measured ball (no free stretch of 0.3 s or more in this window)")
    return "\n".join(lines)


def main(argv: Sequence[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    progress = (lambda message: None) if args.quiet else (lambda message: print(f"[twin_video] {message}", file=sys.stderr, flush=True))
    try:
        print(film(args, progress))
    except (RenderError, DataError, ParamsError, BagError, ValueError) as error:
        print(f"twin_video: {str(error).strip().splitlines()[0]}", file=sys.stderr)
        return 2
    except OSError as error:
        print(f"twin_video: {error.strerror or error}: {error.filename or ''}".rstrip(": "), file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("twin_video: interrupted", file=sys.stderr)
        return 130
    return 0


if __name__ == "__main__":
    sys.exit(main())
