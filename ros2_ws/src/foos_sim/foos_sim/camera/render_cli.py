"""render_video: film a simulated or recorded rollout with a synthetic camera, with its ground truth."""
from __future__ import annotations

import argparse
import math
import sys
from pathlib import Path
from typing import Optional

import numpy as np
import yaml

from foos_core.camera_model import load_camera
from foos_core.command_line import run_cli
from foos_core.markers import DEFAULT_MARKERS_FILE, load_markers
from foos_core.names import BALL_DETECTION_TOPIC, BALL_STATE_TOPIC, JOINT_STATES_TOPIC
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.model_builder import build_mjcf
from foos_sim.simulation import TableSimulation

from .errors import RenderError
from .hands import HandScript
from .recorded import RecordedStates, read_recorded_states
from .render import (
    MEASURED_COLOUR,
    BallMark,
    BallOverlay,
    FrameOverlay,
    FrameTruth,
    RenderOptions,
    SceneRenderer,
    write_camera,
    write_joints,
    write_truth,
    write_video,
)
from .scenarios import SimRollout, StateReplay, detections_at
from .scene import BALL_COLOURS, FIGURE_COLOURS

DESCRIPTION = """\
Render a video of the simulated table (or of a bag of ball and rod states) as a camera would film it,
and write the ground truth next to it:
  OUT.mp4            the video (mp4v), frame k exposed around t = k / fps
  OUT.truth.csv      frame,t,x,y,z,vx,vy,vz,visible: the ball centre in the table frame at each frame
                     time (NaN while the ball is picked up); visible = fraction of the ball in view
                     (with --visibility, else NaN)
  OUT.camera.yaml    the camera used (pose, fov, size, fps, distortion) and its OpenCV intrinsics
  OUT.markers.yaml   the ArUco tag layout in the video, ready for `track_video --markers`
  OUT.joints.csv     frame,t and the 16 rod joints at each frame time (what /joint_states would say)

Examples:
  render_video out/roll.mp4 --scenario rolls --duration 20 --params-file tilted.yaml
  render_video out/play.mp4 --camera oblique --fps 60 --ball-color yellow --blur 4 --distortion -0.2,0.05
  render_video out/replay.mp4 --bag recorded_bag --camera overhead
  render_video out/game.mp4 --bag out/game --no-shadows --noise 0 --fps 15   (a game to watch, quickly)
  render_video out/clip.mp4 --camera fisheye --ball-color yellow --blur 4   (1080p, 25 fps, fisheye)
  render_video out/hands.mp4 --ball-color orange --hide-every 1 --hide-for 0.3 --hands   (a hand picks it up)
  render_video out/same.mp4 --ball-color yellow --home-color yellow --away-color black   (figures of its colour)
  render_video out/fish.mp4 --fps 60 --fovy 80 --fisheye 0.05,-0.02,0.01,-0.005

A lens is applied to an ideal pinhole render by remapping. For --fisheye (OpenCV's cv2.fisheye
equidistant model, r = f theta_d; --fovy is then the field of its r = f theta part) that render has the
same focal length and is made larger, up to 1.5 times the output per axis; rays beyond it (the corners
of a very wide lens) are black, like a real fisheye's vignette. OUT.camera.yaml's `intrinsics:` block
(with `model: fisheye`) is what track_video --intrinsics and tracker_node take.

--bag replays /ball/state (the ball in the scene) and /joint_states (the rods), and draws the measured
ball of /ball/detection over the image as a magenta dot, with a legend. A bag without /joint_states (a
table without rod encoders) is filmed with the rods centred and the figures hanging; without /ball/state,
only the measured ball is drawn. To see where a simulated table parts from a measurement, use
`ros2 run foos_calibration twin_video`.
"""


def parse_colour(text: str, names: dict = BALL_COLOURS) -> tuple[float, float, float]:
    if text in names:
        return names[text]
    try:
        rgb = tuple(float(v) for v in text.split(","))
    except ValueError:
        rgb = ()
    if len(rgb) != 3 or not all(0 <= v <= 1 for v in rgb):
        raise argparse.ArgumentTypeError(f"`{text}` is not one of {sorted(names)} nor R,G,B in [0, 1]")
    return rgb


def parse_figure_colour(text: str) -> tuple[float, float, float]:
    return parse_colour(text, FIGURE_COLOURS)


def parse_floats(text: str) -> tuple[float, ...]:
    try:
        values = tuple(float(v) for v in text.split(",") if v.strip())
    except ValueError:
        raise argparse.ArgumentTypeError(f"`{text}` is not a comma-separated list of numbers") from None
    if not all(math.isfinite(v) for v in values):
        raise argparse.ArgumentTypeError("values must be finite")
    return values


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="render_video", description=DESCRIPTION,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("out", help="output video path (.mp4); the truth, camera and markers files go next to it")
    src = p.add_argument_group("what is filmed")
    src.add_argument("--scenario", choices=("play", "rolls"), default="play",
                     help="play: rods moving and kicking, random rolls 0.3-3 m/s; rolls: rods lifted, "
                          "free rolls (for calibration). Default play")
    src.add_argument("--bag", help="replay /ball/state and /joint_states from this bag instead of simulating, and draw "
                                   "its measured ball (/ball/detection)")
    src.add_argument("--params-file", help="table parameter file for the simulation (default: the nominal table)")
    src.add_argument("--duration", type=float, default=5.0, help="seconds of video (default 5; a bag: its length)")
    src.add_argument("--hide-every", type=float, default=0.0,
                     help="take the ball out of sight about every this many seconds, for --hide-for s (default never)")
    src.add_argument("--hide-for", type=float, default=0.4)
    src.add_argument("--no-ball", action="store_true", help="the ball is never in sight (for false-detection tests)")
    src.add_argument("--hands", action="store_true",
                     help="a player's hand and forearm (skin tone) reaches in from the nearest long side, covers the "
                          "ball while it is picked up (--hide-every) and goes back out; needs --hide-every")
    src.add_argument("--seed", type=int, default=0)
    cam = p.add_argument_group("camera")
    cam.add_argument("--camera", default="overhead", help="overhead, oblique, or a camera YAML (default overhead)")
    cam.add_argument("--width", type=int)
    cam.add_argument("--height", type=int)
    cam.add_argument("--fps", type=float)
    cam.add_argument("--fovy", type=float, help="vertical field of view, degrees")
    lens = cam.add_mutually_exclusive_group()
    lens.add_argument("--distortion", type=parse_floats, help="OpenCV k1,k2[,p1,p2,k3] radial/tangential lens distortion")
    lens.add_argument("--fisheye", type=parse_floats, metavar="K1,K2,K3,K4",
                      help="a fisheye lens (cv2.fisheye) with these coefficients (0,0,0,0: pure equidistant)")
    cam.add_argument("--markers", default=str(DEFAULT_MARKERS_FILE), help="tag layout to place (default: the shipped one)")
    look = p.add_argument_group("realism")
    look.add_argument("--ball-color", type=parse_colour, default=BALL_COLOURS["white"],
                      help=f"{', '.join(BALL_COLOURS)} or R,G,B in [0, 1] (default white)")
    look.add_argument("--home-color", type=parse_figure_colour,
                      help=f"the home figures' colour: {', '.join(FIGURE_COLOURS)} or R,G,B (default foos_sim's red)")
    look.add_argument("--away-color", type=parse_figure_colour, help="the away figures' colour (default foos_sim's blue)")
    look.add_argument("--blur", type=int, default=1, help="sub-frames averaged per frame for motion blur (default 1 = none)")
    look.add_argument("--exposure", type=float, default=0.5, help="shutter open fraction of the frame interval (default 0.5)")
    look.add_argument("--noise", type=float, default=1.5, help="sensor noise std, 8-bit levels (default 1.5)")
    look.add_argument("--lighting", type=float, default=1.0, help="light intensity scale (default 1)")
    look.add_argument("--visibility", action="store_true", help="measure the visible fraction of the ball per frame (2x slower)")
    look.add_argument("--no-shadows", action="store_true",
                      help="render without shadows: 3x faster on a software renderer, for a video to watch")
    p.add_argument("--overwrite", action="store_true", help="replace existing output files")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def render_video(args: argparse.Namespace) -> int:
    out = Path(args.out)
    if out.suffix.lower() != ".mp4":
        raise RenderError(f"{out}: the output must be an .mp4 file")
    stem = out.with_suffix("")
    outputs = [out, Path(f"{stem}.truth.csv"), Path(f"{stem}.camera.yaml"), Path(f"{stem}.markers.yaml"),
               Path(f"{stem}.joints.csv")]
    existing = [str(o) for o in outputs if o.exists()]
    if existing and not args.overwrite:
        raise RenderError(f"{existing[0]} exists (use --overwrite to replace it)")
    camera = load_camera(args.camera).with_(width=args.width, height=args.height, fps=args.fps, fovy=args.fovy,
                                            distortion=args.distortion)
    if args.fisheye is not None:
        if len(args.fisheye) != 4:
            raise RenderError(f"--fisheye takes 4 coefficients k1,k2,k3,k4, not {len(args.fisheye)}")
        camera = camera.with_(model="fisheye", distortion=args.fisheye)
    elif args.distortion is not None and camera.fisheye:
        raise RenderError("--distortion is for a pinhole lens; this camera is a fisheye (use --fisheye k1,k2,k3,k4)")
    if camera.width % 2 or camera.height % 2:
        raise RenderError("width and height must be even (mp4v)")
    for name in ("duration", "exposure", "lighting"):
        if not (getattr(args, name) > 0 and math.isfinite(getattr(args, name))):
            raise RenderError(f"--{name} must be a positive number")
    if args.hands and (args.bag or args.hide_every <= 0 or args.no_ball):
        raise RenderError("--hands picks the ball up: it needs a simulated rollout with --hide-every > 0 (no --bag, "
                          "no --no-ball)")
    if args.blur < 1 or args.noise < 0 or args.hide_every < 0 or args.hide_for <= 0:
        raise RenderError("--blur >= 1, --noise >= 0, --hide-every >= 0 and --hide-for > 0 are required")
    layout = load_markers(args.markers)
    params = load_params(args.params_file)
    sim = TableSimulation(params=params)
    if args.bag:
        recorded = read_recorded_states(args.bag)
        rollout = StateReplay(sim, recorded)
        duration = min(args.duration, rollout.duration) if "--duration" in sys.argv else rollout.duration
        if recorded.joint_t is None:
            print(f"render_video: {args.bag} has no {JOINT_STATES_TOPIC} (a table without rod encoders): "
                  "the rods are drawn centred, figures hanging", file=sys.stderr)
    else:
        rollout = SimRollout(sim, args.scenario, seed=args.seed, hide_every=args.hide_every, hide_for=args.hide_for,
                             no_ball=args.no_ball)
        duration = args.duration
    n_frames = int(math.floor(duration * camera.fps)) + 1
    options = RenderOptions(camera=camera, ball_colour=args.ball_color, subframes=args.blur, exposure=args.exposure,
                            noise=args.noise, lighting=args.lighting, visibility=args.visibility, seed=args.seed,
                            hands=args.hands, home_colour=args.home_color, away_colour=args.away_color,
                            shadows=not args.no_shadows)
    ball_radius = TableGeometry.from_params(params).ball_radius
    overlay = measured_overlay(recorded, camera, args.ball_color, ball_radius) if args.bag else None
    hand_at = HandScript(rollout).pose if args.hands else None
    renderer = SceneRenderer(build_mjcf(params=params), layout, options)
    truths: list[FrameTruth] = []
    try:
        write_video(out, renderer, rollout.state_at, n_frames, truths, hand_at, overlay, args.quiet)
    finally:
        renderer.close()
        # Whatever was rendered keeps its truth, even after Ctrl-C.
        if truths:
            write_truth(outputs[1], truths)
            write_joints(outputs[4], truths)
    write_camera(outputs[2], camera)
    outputs[3].write_text(yaml.safe_dump({
        "dictionary": layout.dictionary, "size": layout.size,
        "markers": {int(i): [float(v) for v in p] for i, p in sorted(layout.positions.items())},
    }, sort_keys=False))
    visible = np.array([t.visible for t in truths])
    print(f"render_video: {len(truths)} frames {camera.width}x{camera.height} @ {camera.fps:g} fps -> {out}"
          + (f" (ball at least half visible in {np.mean(visible >= 0.5):.0%} of frames)" if args.visibility else ""))
    return 0


def measured_overlay(recorded: RecordedStates, camera, ball_colour, ball_radius: float) -> Optional[FrameOverlay]:
    """Draws the bag's measured ball (/ball/detection, at each frame's time) over the rendered one, with a legend;
    None when the bag has no detections."""
    if recorded.detection_t is None:
        return None
    scene_ball = BallMark(f"ball: {BALL_STATE_TOPIC}", tuple(int(round(255 * c)) for c in reversed(ball_colour)), "disc")
    measured = BallMark(f"measured: {BALL_DETECTION_TOPIC}", MEASURED_COLOUR, "dot")
    draw = BallOverlay(camera, [scene_ball, measured] if recorded.t is not None else [measured], ball_radius)

    def overlay(k: int, image: np.ndarray, truth: FrameTruth) -> None:
        seen = detections_at(recorded.detection_t, recorded.detection_position, [recorded.start + truth.t])[0]
        draw(image, [None, seen] if recorded.t is not None else [seen], caption=f"t = {truth.t:.2f} s")

    return overlay


def main(argv=None) -> None:
    run_cli(build_parser(), render_video, argv)


if __name__ == "__main__":
    main()
