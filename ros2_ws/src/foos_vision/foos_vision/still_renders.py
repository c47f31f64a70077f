"""`bench_vision --still-renders`: the still finder (still_ball) on single renders of the simulated camera, with and
without the ball verifier, on the same candidates.

The set: foos_sim's LiveCamera at 1280x720 with shadows, the overhead camera with seeds 7 and 11 and the oblique camera
with seed 11; per seed, 10 ball positions (`rng = numpy.random.default_rng(seed)`; x = rng.uniform(-0.3, 0.3, 10),
then y = rng.uniform(-0.55, 0.55, 10)), each filmed with a white, a yellow and an orange ball, rods centred and
hanging. The same set as the 28 Nov stills logs (stills-4: 79 of 90 found, none wrong). Found: within one ball
diameter (the camera's own, at the ball) of the true centre; wrong: more than two. The verifier was trained on other
renders (verifier_training: other seeds, cameras, colours and poses), never on these.
"""
from __future__ import annotations

import itertools
import math
from typing import Iterator, Optional

import numpy as np

from foos_sim.camera.live import LiveCamera, LiveCameraConfig
from foos_sim.simulation import TableSimulation

from .detection.ball_verifier import BallVerifier
from .detection.still_ball import StillBallFinder, _pick, _verified_pick, verify

SETS = (("overhead", 7), ("overhead", 11), ("oblique", 11))
COLOURS = ("white", "yellow", "orange")
POSITIONS = 10


def still_render_set() -> Iterator[tuple[str, int, str, np.ndarray, tuple[float, float, float]]]:
    """The set, one render at a time: (camera name, seed, ball colour, the image, the true (u, v, diameter) in px)."""
    for camera_name, seed in SETS:
        rng = np.random.default_rng(seed)
        xs, ys = rng.uniform(-0.3, 0.3, POSITIONS), rng.uniform(-0.55, 0.55, POSITIONS)
        for colour in COLOURS:
            camera = LiveCamera(LiveCameraConfig(rate=60, width=1280, height=720, camera=camera_name,
                                                 ball_colour=colour, shadows=True, seed=seed))
            try:
                for x, y in zip(xs, ys):
                    sim = TableSimulation()
                    sim.reset(ball_position=(float(x), float(y)), ball_velocity=(0.0, 0.0))
                    image = camera.capture(sim.data.qpos.copy())
                    centre = sim.ball_position()[None, :]
                    u, v = camera.camera.project(centre)[0]
                    depth = float(camera.camera.depth(centre)[0])
                    diameter = 2 * camera.camera.camera_matrix()[0, 0] * sim.ball_radius / depth
                    yield camera_name, seed, colour, image, (float(u), float(v), float(diameter))
            finally:
                camera.close()


def run_still_renders(verifier: Optional[BallVerifier], echo=print) -> dict[str, dict[str, int]]:
    finder = StillBallFinder()
    keys = ("rules", "+verifier") if verifier is not None else ("rules",)
    rows = {key: {"found": 0, "wrong": 0, "none": 0} for key in keys}
    echo(f"{'set':<14} {'colour':<7} {'rules found/wrong':>17} {'+verifier found/wrong':>21}")
    for (camera_name, seed, colour), renders in itertools.groupby(still_render_set(), key=lambda render: render[:3]):
        counts = {key: [0, 0] for key in ("rules", "+verifier")}
        for *_, image, (u, v, diameter) in renders:
            field, candidates = finder.find(image)
            picks = {"rules": _pick(candidates, field)}
            if verifier is not None:
                picks["+verifier"] = None
                if field is not None:
                    verify(verifier, image, field, candidates)
                    picks["+verifier"] = _verified_pick(candidates, field)
            for key, ball in picks.items():
                if ball is None:
                    rows[key]["none"] += 1
                    continue
                error = math.hypot(ball.u - u, ball.v - v)
                counts[key][0] += error <= diameter
                counts[key][1] += error > 2 * diameter
                rows[key]["found"] += error <= diameter
                rows[key]["wrong"] += error > 2 * diameter
        echo(f"{camera_name + ' ' + str(seed):<14} {colour:<7} {counts['rules'][0]:>8} / {counts['rules'][1]:<6} "
             f"{counts['+verifier'][0]:>10} / {counts['+verifier'][1]}")
    total = len(SETS) * len(COLOURS) * POSITIONS
    for key, row in rows.items():
        echo(f"still renders, {key}: {row['found']} of {total} found, {row['wrong']} wrong, {row['none']} none")
    return rows
