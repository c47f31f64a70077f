"""The camera in the loop, measured: sim_node films the table (camera_rate), tracker_node tracks the images as
on a real table, and a probe node compares its detections with sim_node's true ball and times the chain.

    ./scripts/bench_camera_loop [--rate 60] [--width 640] [--height 480] [--frames 300]

What it prints:
  - frames filmed and the filming rate (frames per wall second: the software renderer's cost sets it);
  - how long the tracker took to start (the sim time of its first detection: it finds the tags and votes
    the ball's colour first), then detections per frame with the ball on the field from there on (a busy
    tracker drops frames, as on a real table), their median and p95 error against /sim/ball/state at the
    detection's stamp (the stamp is the sim time of the frame it was found in);
  - the chain's latency past the camera: from an image's publication to the arrival of the detection made from
    it (two DDS hops and the tracker's work; a real camera adds its exposure and read-out before that). The
    probe takes the publication from the frame's /camera/camera_info, which sim_node publishes right after the
    image and which is small enough to arrive at once (the probe does not take the images themselves).
sim_node runs on sim time as fast as it can, so each frame shows the state of its own stamp whatever the
renderer costs.
"""
from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rclpy
from geometry_msgs.msg import PointStamped
from nav_msgs.msg import Odometry
from rclpy.executors import SingleThreadedExecutor
from sensor_msgs.msg import CameraInfo

from foos_core.names import (
    BALL_DETECTION_TOPIC,
    BALL_STATE_TOPIC,
    CAMERA_IMAGE_TOPIC,
    CAMERA_INFO_TOPIC,
    SIM_BALL_STATE_TOPIC,
)
from foos_core.stamps import stamp_to_seconds
from foos_core.table_geometry import TableGeometry

STARTUP_S = 30.0  # s for tracker_node to show up in the graph


@dataclass
class LoopRecord:
    """What the probe heard: images by stamp (wall time of arrival), detections, the true ball."""

    rate: float  # Hz, the camera's: a frame every 1 / rate of sim time from 0
    images: dict  # stamp -> wall time of arrival of the frame's camera info
    infos: list  # CameraInfo messages
    detections: np.ndarray  # (N, 4): stamp, x, y, wall time of arrival
    truth: np.ndarray  # (M, 4): stamp, x, y, z
    publishers: dict  # topic -> publisher count seen while the loop ran
    filming_rate: float  # frames per wall second


@dataclass
class LoopSummary:
    frames: int
    first_detection: float  # s of sim time: the tracker's start
    start_wall_s: float  # s of wall time from the first frame's arrival to the first detection's
    frames_on_field: int  # from the first detection on
    detections: int
    median_error_mm: float
    p95_error_mm: float
    latency_median_ms: float
    latency_p95_ms: float
    filming_rate: float

    def line(self) -> str:
        return (f"{self.frames} frames ({self.filming_rate:.1f}/s filmed), first detection at {self.first_detection:.2f} s "
                f"({self.start_wall_s:.1f} s of wall time after the first frame), "
                f"then {self.detections} detections for {self.frames_on_field} frames with the ball on the field, "
                f"error median {self.median_error_mm:.2f} mm "
                f"p95 {self.p95_error_mm:.2f} mm, latency median {self.latency_median_ms:.1f} ms "
                f"p95 {self.latency_p95_ms:.1f} ms")


def _spawn(env: dict, package: str, executable: str, params: list[str], log) -> subprocess.Popen:
    args = ["ros2", "run", package, executable, "--ros-args"]
    for p in params:
        args += ["-p", p]
    return subprocess.Popen(args, env=env, stdout=log, stderr=subprocess.STDOUT, start_new_session=True)


def _stop(process: subprocess.Popen) -> None:
    if process.poll() is None:
        os.killpg(process.pid, signal.SIGINT)
        try:
            process.wait(10)
        except subprocess.TimeoutExpired:
            os.killpg(process.pid, signal.SIGKILL)
            process.wait()


def run_loop(domain: int, rate: float, width: int, height: int, frames: int, log_dir: Path,
             timeout: float = 120.0, seed: int = 4, tracked_frames: int = 0) -> LoopRecord:
    """Start tracker_node and sim_node (camera on, sim time, flat out) in `domain` and listen until `frames`
    images have arrived and `tracked_frames` of them after the tracker's first detection (or `timeout` s of
    wall time); RuntimeError (with the log's tail) when a node fails.

    The sim films as fast as it renders, so how many frames pass before the tracker has fitted the tags and
    voted the ball's colour depends on the machine's load: counting frames after the start keeps the tracked
    stretch the same on a quiet and a loaded machine."""
    env = dict(os.environ, ROS_DOMAIN_ID=str(domain), PYTHONUNBUFFERED="1")
    context = rclpy.Context()
    rclpy.init(context=context, domain_id=domain)
    node = rclpy.create_node("camera_loop_probe", context=context)
    images: dict[float, float] = {}
    infos: list = []
    detections: list = []
    truth: list = []

    def on_info(msg: CameraInfo) -> None:
        images.setdefault(stamp_to_seconds(msg.header.stamp), time.monotonic())
        infos.append(msg)

    node.create_subscription(CameraInfo, CAMERA_INFO_TOPIC, on_info, 100)
    node.create_subscription(PointStamped, BALL_DETECTION_TOPIC, lambda m: detections.append(
        (stamp_to_seconds(m.header.stamp), m.point.x, m.point.y, time.monotonic())), 100)
    node.create_subscription(Odometry, SIM_BALL_STATE_TOPIC, lambda m: truth.append(
        (stamp_to_seconds(m.header.stamp), m.pose.pose.position.x, m.pose.pose.position.y, m.pose.pose.position.z)), 200)
    executor = SingleThreadedExecutor(context=context)
    executor.add_node(node)
    logs = {name: open(log_dir / f"{name}.log", "wb") for name in ("tracker", "sim")}
    processes: list[subprocess.Popen] = []
    publishers: dict[str, int] = {}
    try:
        processes.append(_spawn(env, "foos_vision", "tracker_node", [], logs["tracker"]))
        end = time.monotonic() + STARTUP_S
        while time.monotonic() < end and node.count_publishers(BALL_DETECTION_TOPIC) == 0:
            executor.spin_once(timeout_sec=0.1)
        if node.count_publishers(BALL_DETECTION_TOPIC) == 0:
            raise RuntimeError(f"tracker_node did not start: {_tail(log_dir / 'tracker.log')}")
        processes.append(_spawn(env, "foos_sim", "sim_node", [
            f"camera_rate:={float(rate)}", f"camera_width:={int(width)}", f"camera_height:={int(height)}",
            "publish_clock:=true", "real_time_factor:=0", f"seed:={seed}"], logs["sim"]))
        start = time.monotonic()
        end = start + timeout
        def tracked() -> int:
            return sum(1 for s in images if s >= detections[0][0]) if detections else 0

        while time.monotonic() < end and (len(images) < frames or tracked() < tracked_frames):
            executor.spin_once(timeout_sec=0.05)
            for process, name in zip(processes, ("tracker", "sim")):
                if process.poll() is not None:
                    raise RuntimeError(f"{name} node exited: {_tail(log_dir / f'{name}.log')}")
        filming_rate = len(images) / max(time.monotonic() - start, 1e-9)
        for topic in (BALL_DETECTION_TOPIC, BALL_STATE_TOPIC, CAMERA_IMAGE_TOPIC):
            publishers[topic] = node.count_publishers(topic)
        end = time.monotonic() + 1.0  # the last frames' detections
        while time.monotonic() < end:
            executor.spin_once(timeout_sec=0.05)
    finally:
        for process in reversed(processes):
            _stop(process)
        for log in logs.values():
            log.close()
        executor.shutdown()
        node.destroy_node()
        rclpy.shutdown(context=context)
    return LoopRecord(float(rate), images, infos, np.array(detections).reshape(-1, 4), np.array(truth).reshape(-1, 4),
                      publishers, filming_rate)


def _tail(path: Path) -> str:
    lines = path.read_text(errors="replace").strip().splitlines()
    return " | ".join(lines[-3:]) if lines else "(no output)"


def frame_times(rate: float, start: float, end: float) -> np.ndarray:
    """The sim times sim_node filmed between start and end: every 1 / rate from 0 (each taken at the physics
    step nearest it, so within half a step of these)."""
    first, last = int(np.ceil(start * rate)), int(np.floor(end * rate))
    return np.arange(first, last + 1) / rate


def summarise(record: LoopRecord) -> LoopSummary:
    """Detections against the true ball at their stamps, and the latency past the camera."""
    geometry = TableGeometry.nominal()
    t, x, y, z = record.truth.T
    det = record.detections[(record.detections[:, 0] >= t[0]) & (record.detections[:, 0] <= t[-1])]
    first = float(det[:, 0].min()) if len(det) else float("nan")
    stamps = frame_times(record.rate, first - 0.5 / record.rate, t[-1]) if len(det) else np.zeros(0)
    on_field = ((np.abs(np.interp(stamps, t, x)) <= geometry.half_width)
                & (np.abs(np.interp(stamps, t, y)) <= geometry.half_length)
                & (np.interp(stamps, t, z) < 2 * geometry.ball_radius))
    error = np.hypot(det[:, 1] - np.interp(det[:, 0], t, x), det[:, 2] - np.interp(det[:, 0], t, y))
    latency = np.array([arrival - record.images[s] for s, _, _, arrival in det if s in record.images])
    pct = lambda values, q: float(np.percentile(values, q)) if len(values) else float("nan")  # noqa: E731
    start_wall = (float(det[:, 3].min()) - min(record.images.values())) if len(det) and record.images else float("nan")
    return LoopSummary(len(record.images), first, start_wall, int(on_field.sum()), len(det), 1000 * pct(error, 50), 1000 * pct(error, 95),
                       1000 * pct(latency, 50), 1000 * pct(latency, 95), record.filming_rate)


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(prog="bench_camera_loop", description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--rate", type=float, default=60.0, help="sim_node's camera_rate, Hz (default 60)")
    parser.add_argument("--width", type=int, default=640, help="image width, px (default 640)")
    parser.add_argument("--height", type=int, default=480, help="image height, px (default 480)")
    parser.add_argument("--frames", type=int, default=300, help="frames to film (default 300)")
    parser.add_argument("--domain", type=int, default=77, help="ROS_DOMAIN_ID of the run (default 77)")
    parser.add_argument("--timeout", type=float, default=300.0, help="s of wall time at most (default 300)")
    args = parser.parse_args(argv)
    if args.rate <= 0 or args.frames < 10 or args.width < 16 or args.height < 16:
        print("bench_camera_loop: error: --rate > 0, --frames >= 10, --width and --height >= 16", file=sys.stderr)
        return 2
    with tempfile.TemporaryDirectory(prefix="camera_loop_") as logs:
        try:
            record = run_loop(args.domain, args.rate, args.width, args.height, args.frames, Path(logs), args.timeout)
        except RuntimeError as error:
            print(f"bench_camera_loop: error: {error}", file=sys.stderr)
            return 1
    if len(record.truth) < 2 or not record.images:
        print("bench_camera_loop: error: no frames or no true ball arrived", file=sys.stderr)
        return 1
    print(f"camera loop at {args.rate:g} Hz, {args.width}x{args.height}: {summarise(record).line()}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
