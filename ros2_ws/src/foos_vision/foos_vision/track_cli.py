"""track_video: a video file to a bag of ball detections in the table frame (the offline tracker)."""
from __future__ import annotations

import argparse
import math
import sys
import tempfile
import time
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from foos_bag import BagWriter, write_ball_detections, write_ball_states
from foos_core.camera_model import load_intrinsics
from foos_core.command_line import run_cli
from foos_core.field_size import parse_field_size, write_field_sized
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params

from .annotate import Annotator
from .bag_inputs import read_joint_track
from .camera.field_auto import find_field_corners, is_auto, still_frames
from .camera.field_corners import FieldCorners, field_reference, option_given, parse_field_corners
from .camera.figure_mask import FigureGeometry
from .detection.detector import BALL_COLOR_NAMES
from .errors import MarkersError, VisionError
from .tracking.backfill import OfflineTracker
from .tracking.tracker import BallTracker, TrackerConfig, choose_colour
from .tracking.velocity import central_differences
from .video_io import VideoReader

LOW_CONFIDENCE = 0.5  # --field-corners auto: below this the run warns

DESCRIPTION = """\
Track the ball in a video of the table and write a rosbag2 bag (MCAP) with
  /ball/detection  geometry_msgs/PointStamped, frame `table`, stamp = frame time (index / fps + --start-time)
  /ball/state      nav_msgs/Odometry, position and constant-velocity Kalman velocity
A frame where the ball is not found gives no detection. The tags of the markers file give the
homography to the table (refitted every --tag-interval frames; the last good fit is kept while tags
are hidden). Optional outputs: the paper's CSVs and an annotated video or PNG.

A table without tags, filmed by a camera that does not move: --field-corners U1,V1,U2,V2,U3,V3,U4,V4 in
place of --markers, the pixels where the playing surface meets the walls at the table frame's corners
(-x,-y), (+x,-y), (+x,+y), (-x,+y) (+y toward the away goal, the home team attacks +y; seen from above the
four go round counter-clockwise). A corner hidden behind a wall is given where it would be seen; a pixel
or two off is fine: on the first frame the corners are fitted to the table's edges seen (the felt against
the walls, the walls' tops), and the run says so. A table that is not the regulation one needs only
--field-size LENGTH,WIDTH (m: LENGTH along y between the end walls, WIDTH along x between the side walls):
its rods and figures keep the regulation layout's proportions (foos_core.field_size); --params-file
describes a table in full instead (or is the table --field-size resizes). The ball plane is reached by
the parallax the camera implies (--intrinsics when given, else the focal length the corners reveal).

--field-corners auto finds the corners in the first 2 s (the felt's outline, its four sides fitted with
lines, the walls' height where the camera is behind one) and prints them with how sure it is; then they
are used as given ones. The home end (-y) is taken to be the left end of a field lying across the image,
the bottom end of one lying up it (no picture tells the ends apart); for the other way round give the
printed corners in the order 3, 4, 1, 2. No field found: one line, exit 2, no bag written.

Offline, each new track is also followed backward in time from its first detections, over the
frames just before it, to recover a ball that came out half hidden from under a rod or a foot
before the track started (tracker_node, online, cannot do this; --no-backfill tracks as it does).

With --joint-states BAG (a bag with /joint_states: the rod encoders of an instrumented table, or any bag
the simulator wrote) the figures are masked out: each figure's box, posed from the 16 rod joints at the
frame's time (interpolated between readings; stamps must share the video's clock, see --start-time), is
projected into the image, and pixels under it are not ball evidence. That separates a ball from figures
of its colour. Frames more than 0.1 s from any reading are tracked without the mask.

Examples:
  track_video game.mp4 --markers table_markers.yaml --out game_bag
  track_video game.mp4 --field-corners 412,880,1510,875,1398,170,520,168 --field-size 1.12,0.64 --out bag
  track_video game.mp4 --field-corners auto --field-size 1.12,0.64 --out bag
  track_video game.mp4 --markers m.yaml --out bag --joint-states game_rods_bag --start-time 12.5
  track_video game.mp4 --markers m.yaml --out bag --ball-color yellow --intrinsics cam.yaml \\
      --csv-pixels px.csv --csv-metres m.csv --annotate seen.mp4
Exit status: 0 done, 1 ran but the result is incomplete (video cut short), 2 bad input (no bag written).
"""


def build_parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(prog="track_video", description=DESCRIPTION,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("video", help="video file (anything OpenCV/FFmpeg decodes: mp4, avi, mkv, ...)")
    p.add_argument("--markers", help="markers YAML: ArUco dictionary, tag size, tag centres [x, y, z] in m")
    p.add_argument("--field-corners", metavar="U1,V1,U2,V2,U3,V3,U4,V4|auto",
                   help="instead of --markers: pixels of the playing field's corners at (-x,-y), (+x,-y), (+x,+y), "
                        "(-x,+y) of the table frame, or auto to find them in the first frames (see above)")
    p.add_argument("--out", required=True, help="bag directory to create (must not exist)")
    p.add_argument("--ball-color", default="auto", choices=("auto",) + BALL_COLOR_NAMES,
                   help="ball colour; auto picks it from the first frames (default auto)")
    p.add_argument("--start-time", type=float, default=0.0, help="seconds added to every frame time (default 0)")
    p.add_argument("--fps", type=float, help="frame rate, when the container does not tell it (or tells it wrong)")
    p.add_argument("--intrinsics", help="camera intrinsics YAML from calibrate_camera (undistorts tags and ball)")
    p.add_argument("--tag-interval", type=int, default=30, help="frames between tag refits (default 30)")
    p.add_argument("--storage", choices=("mcap", "sqlite3"), default="mcap")
    p.add_argument("--csv-pixels", help="also write t,u,v (pixels) of every detection")
    p.add_argument("--csv-metres", help="also write t,x,y,vx,vy (m, m/s; central differences, as in the paper)")
    p.add_argument("--annotate", help="also write what the tracker saw: a video (.mp4) or the last frame with the track (.png)")
    p.add_argument("--no-backfill", action="store_true",
                   help="forward pass only, as tracker_node tracks live (no backward search before a track's start)")
    p.add_argument("--joint-states", metavar="BAG",
                   help="bag with /joint_states (the 16 rod joints): mask out the figures (see above)")
    p.add_argument("--params-file", help="foos_sim table parameter file: the field's size, the figures for the mask, "
                                         "where the rods are (default: the regulation table)")
    p.add_argument("--field-size", metavar="LENGTH,WIDTH",
                   help="a table that is not the regulation one: its field in m, LENGTH along y between the end walls, "
                        "WIDTH along x between the side walls (e.g. 1.12,0.64); the rods keep the regulation layout's "
                        "proportions")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    return p


def track_video(args: argparse.Namespace) -> int:
    if not math.isfinite(args.start_time):
        raise VisionError("--start-time must be a finite number of seconds")
    if args.tag_interval < 1:
        raise VisionError("--tag-interval must be >= 1")
    BagWriter.check_new_path(args.out)
    for extra in (args.csv_pixels, args.csv_metres, args.annotate):
        if extra and Path(extra).exists():
            raise VisionError(f"{extra} exists; choose a new output path")
    if args.annotate and Path(args.annotate).suffix.lower() not in (".mp4", ".png"):
        raise VisionError("--annotate takes an .mp4 or .png path")
    intrinsics = load_intrinsics(args.intrinsics) if args.intrinsics else None
    if is_auto(args.field_corners) and not option_given(args.markers):
        layout = _found_corners(args, intrinsics)
    else:
        layout = field_reference(args.markers, args.field_corners)
    corners = layout if isinstance(layout, FieldCorners) else None
    reader = VideoReader(args.video, args.fps)
    if corners is not None and reader.width > 0 and reader.height > 0:  # else checked on the first frame
        corners.check_in_image(reader.width, reader.height)
    config = TrackerConfig(ball_color=args.ball_color, intrinsics=intrinsics, tag_interval=args.tag_interval,
                           params_file=args.params_file)
    figures, joints = None, None
    if args.joint_states:
        joints = read_joint_track(args.joint_states)
        figures = FigureGeometry(args.params_file)

    def joints_at(stamp: float):
        return None if joints is None else joints.at(stamp)

    if args.ball_color == "auto":
        # Settle the colour on the first seconds first, so the first frames are tracked with it too.
        probe = VideoReader(args.video, args.fps)
        frames = (frame for index, _, frame in probe.frames() if index < 10 * probe.fps)
        config.ball_color = choose_colour(frames, layout, config, probe.fps, figures,
                                          lambda t: joints_at(t + args.start_time)) or "auto"
        probe.close()
    if joints is not None and reader.declared_frames and not joints.covers(
            args.start_time, args.start_time + reader.declared_frames / reader.fps):
        raise VisionError(f"--joint-states {args.joint_states}: its stamps ({joints.t[0]:.2f}-{joints.t[-1]:.2f} s) "
                          f"do not overlap the video's frame times from --start-time {args.start_time:g} s")
    tracker = BallTracker(layout, config, figures)
    offline = OfflineTracker(tracker, reader.fps, backward=not args.no_backfill)
    annotator = Annotator(tracker) if args.annotate else None
    writer = None
    last_frame = None
    interrupted = False
    started = time.perf_counter()
    try:
        for index, t, frame in tqdm(reader.frames(), total=reader.declared_frames or None, desc="track_video",
                                    unit="frame", disable=args.quiet):
            stamp = t + args.start_time
            detection = offline.process(index, stamp, frame, joints_at(stamp))
            if annotator is not None:
                drawn = annotator.draw(frame, detection)
                if args.annotate.lower().endswith(".mp4"):
                    if writer is None:
                        writer = cv2.VideoWriter(args.annotate, cv2.VideoWriter_fourcc(*"mp4v"), reader.fps,
                                                 (frame.shape[1], frame.shape[0]))
                    writer.write(drawn)
                last_frame = drawn
    except KeyboardInterrupt:
        interrupted = True
    finally:
        reader.close()
        if writer is not None:
            writer.release()
    offline.finish()
    tracked = offline.results()
    detections = [r.detection for r in tracked]
    elapsed = time.perf_counter() - started
    stats = tracker.stats
    if corners is None and tracker.stats.tag_fits == 0:
        if stats.tags_seen and not (stats.tags_seen & set(layout.positions)):
            raise MarkersError(f"the video shows tags {sorted(stats.tags_seen)} but the markers file places "
                               f"{layout.ids}: wrong markers file or dictionary")
        if tracker.last_fit_error:
            raise MarkersError(f"no usable tag fit in {stats.frames} frames: {tracker.last_fit_error}")
        raise MarkersError(f"no {layout.dictionary} tags found in {stats.frames} frames of {args.video}")
    if not detections:
        found = "the field's corners were given" if corners is not None else "tags were found"
        raise VisionError(f"no ball found in {stats.frames} frames ({found}; try --ball-color)")
    t = np.array([d.t for d in detections])
    xyz = np.array([[d.x, d.y, d.z] for d in detections])
    velocity = np.array([[r.state[2], r.state[3], 0.0] for r in tracked])
    filtered = np.array([[r.state[0], r.state[1], r.detection.z] for r in tracked])
    with BagWriter(args.out, storage=args.storage) as bag:
        write_ball_detections(bag, t, xyz)
        write_ball_states(bag, t, filtered, velocity)
    if args.csv_pixels:
        np.savetxt(args.csv_pixels, np.array([[d.t, d.u, d.v] for d in detections]), delimiter=",",
                   header="t,u,v", comments="", fmt="%.6f")
    if args.csv_metres:
        v = central_differences(t, xyz[:, :2])
        np.savetxt(args.csv_metres, np.column_stack([t, xyz[:, :2], v]), delimiter=",", header="t,x,y,vx,vy",
                   comments="", fmt="%.6f")
    if args.annotate and args.annotate.lower().endswith(".png") and last_frame is not None:
        points = np.array([[d.u, d.v] for d in detections])
        cv2.polylines(last_frame, [np.round(points).astype(np.int32)], False, (0, 200, 255), 1, cv2.LINE_AA)
        cv2.imwrite(args.annotate, last_frame)
    print(f"track_video: {len(detections)} detections in {stats.frames} frames ({len(detections) / stats.frames:.0%}), "
          f"{_fit_summary(tracker, corners)}, colour {tracker.colour.name}, {stats.frames / elapsed:.0f} frames/s "
          f"-> {args.out}"
          + (f" ({offline.backfilled} found by the backward pass before tracks started)" if offline.backfilled else "")
          + (f"; figure mask in {stats.masked_frames} frames" if joints is not None else ""))
    for tag_id, error in sorted(stats.dropped_tags.items()):
        print(f"track_video: warning: tag {tag_id} is {error * 1000:.0f} mm from where the markers file puts it "
              f"(relative to the other tags); it was left out of the fit - measure it again", file=sys.stderr)
    if interrupted:
        print("track_video: interrupted; the bag holds the frames tracked so far", file=sys.stderr)
        return 130
    if reader.truncated():
        print(f"track_video: error: {args.video} ends after {reader.frames_read} of {reader.declared_frames} frames "
              f"(corrupt or cut short); the bag holds the frames before", file=sys.stderr)
        return 1
    return 0


def _found_corners(args: argparse.Namespace, intrinsics) -> FieldCorners:
    """--field-corners auto: the corners found in the video's first frames (FieldNotFound where there is no field);
    what was found, and how sure, is printed."""
    table = TableGeometry.of(args.params_file)
    wall_height = float(load_params(args.params_file)["field"]["wall_height"])
    probe = VideoReader(args.video, args.fps)
    try:
        frames = still_frames(probe.frames(), probe.fps)
    finally:
        probe.close()
    found = find_field_corners(frames, table.half_width, table.half_length, table.goal_half_width, wall_height,
                               intrinsics)
    print(f"track_video: {found.summary()}")
    if found.confidence < LOW_CONFIDENCE:
        print(f"track_video: warning: the field found is not sure (confidence {found.confidence:.2f}): check it with "
              f"--annotate, or give --field-corners U1,V1,... (or --field-size if the table is not the regulation one)",
              file=sys.stderr)
    return parse_field_corners(list(found.pixels.ravel()), "--field-corners auto")


def _fit_summary(tracker: BallTracker, corners: FieldCorners | None) -> str:
    if corners is None:
        return f"{tracker.stats.tag_fits} tag fits"
    refinement = tracker.view.corner_refinement
    if refinement is None or refinement.edges_used == 0:
        return "field corners as given (none of the table's edges found near them)"
    return (f"field corners fitted to {refinement.edges_used} of the table's edges (moved {refinement.moved_px:.1f} px "
            f"at most)")


def track_video_of_size(args: argparse.Namespace) -> int:
    """track_video, with --field-size's table written to a parameter file that lives for the run."""
    if args.field_size is None:
        return track_video(args)
    length, width = parse_field_size(args.field_size)
    with tempfile.TemporaryDirectory(prefix="track_video_") as folder:
        args.params_file = str(write_field_sized(args.params_file, length, width, Path(folder) / "table.yaml"))
        return track_video(args)


def main(argv=None) -> None:
    run_cli(build_parser(), track_video_of_size, argv)


if __name__ == "__main__":
    main()
