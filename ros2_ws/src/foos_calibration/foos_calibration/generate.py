"""Synthetic measured data: hand-launched rolls on a table with hidden effects, written as a bag.

The hidden effects are injected by a mechanism different from the one calibration fits, so that a
found effect is evidence, not the code agreeing with itself:
- continuous effects (tilt, rolling resistance, viscous damping, air drag, dent) are forces and
  torques applied to the ball through `data.xfrc_applied` of the NOMINAL MuJoCo model, from a Python
  stepping loop. A central force F slows a rolling ball at F / (7/5 m); a slope s (or a dent's local
  gradient) is a force m g s; rolling resistance is a torque against the spin (see `_wrench`);
- wall restitution is a change of the normal velocity when a nominal wall contact ends.
The calibration only ever sees the bag (noisy, 120 fps, with dropouts), never the hidden list.
"""
from __future__ import annotations

import argparse
import json
import math
import sys
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Sequence

import mujoco
import numpy as np
from tqdm import tqdm

from foos_bag import BagWriter, write_ball_detections
from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params
from foos_sim.effects import EFFECT_NAMES, MODEL_EFFECT_NAMES, EffectError
from foos_sim.model_builder import ball_model_from_params

from . import game_styles, games
from .hidden_forces import BallBody, HiddenEffects, ball_wrench, world_spin
from .table_shapes import ShapeError, SurfaceShape, WallSegment, parse_shape, wall_at

CONTROL_STEPS = 20  # physics steps between force updates (1 ms at 20 kHz)
WALL_SLOW_ZONE = 0.01  # m from a wall where the loop steps one physics step at a time


def surrogate_theta(hidden: HiddenEffects, nominal_rolling: float = 0.15) -> np.ndarray:
    """The hidden table in the fitting surrogate's parameters (first dent only)."""
    theta = np.array([hidden.slope[0], hidden.slope[1],
                      hidden.rolling_deceleration if hidden.rolling_deceleration is not None else nominal_rolling,
                      hidden.viscous_rate, hidden.drag_coefficient, 0.0, 0.0, 0.1, 0.0])
    if hidden.dents:
        d = hidden.dents[0]
        theta[5:9] = (d.x, d.y, d.radius, d.depth)
    return theta


class HiddenTable:
    """The nominal ball-only MuJoCo table, driven by hidden forces from a Python loop."""

    def __init__(self, hidden: HiddenEffects, params: dict | None = None):
        self.params = params if params is not None else load_params()
        self.hidden = hidden
        self.model = ball_model_from_params(self.params)
        self.data = mujoco.MjData(self.model)
        ball = self.params["ball"]
        geometry = TableGeometry.from_params(self.params)
        self.radius, self.mass = geometry.ball_radius, float(ball["mass"])
        self.g = float(self.params["gravity"])
        self.nominal_rolling = float(ball["rolling_deceleration"])
        self.nominal_restitution = float(self.params["walls"]["restitution"])
        self.half = np.array([geometry.half_width, geometry.half_length])
        self.ball = BallBody(self.mass, self.radius, self.g, self.nominal_rolling, (geometry.half_width, geometry.half_length))
        self.ball_body = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "ball")
        self.wall_geoms = {
            i for i in range(self.model.ngeom)
            if (mujoco.mj_id2name(self.model, mujoco.mjtObj.mjOBJ_GEOM, i) or "").startswith("wall")
        }
        self._wall_normal: np.ndarray | None = None

    def reset(self, position: Sequence[float], velocity: Sequence[float]) -> None:
        """Ball on the surface at (x, y), rolling without slip at (vx, vy)."""
        mujoco.mj_resetData(self.model, self.data)
        self.data.qpos[:3] = (position[0], position[1], self.radius)
        self.data.qpos[3:7] = (1, 0, 0, 0)
        self.data.qvel[:3] = (velocity[0], velocity[1], 0.0)
        self.data.qvel[3:6] = (-velocity[1] / self.radius, velocity[0] / self.radius, 0.0)
        self._wall_normal = None
        mujoco.mj_forward(self.model, self.data)

    def _wrench(self) -> np.ndarray:
        """The hidden effects' force and torque on the ball now (hidden_forces.ball_wrench)."""
        spin = world_spin(self.data.qpos[3:7], self.data.qvel[3:6])
        return ball_wrench(self.hidden, self.ball, self.data.qpos[:3], self.data.qvel[:3], spin)

    def _wall_contact_normal(self) -> np.ndarray | None:
        for i in range(self.data.ncon):
            c = self.data.contact[i]
            if c.geom1 in self.wall_geoms or c.geom2 in self.wall_geoms:
                normal = np.array(c.frame[:3])
                return normal
        return None

    def near_wall(self) -> bool:
        x, y = self.data.qpos[0], self.data.qpos[1]
        return (abs(x) > self.half[0] - self.radius - WALL_SLOW_ZONE) or (abs(y) > self.half[1] - self.radius - WALL_SLOW_ZONE)

    def step_block(self) -> None:
        """CONTROL_STEPS physics steps with the hidden forces (single steps near a wall)."""
        self.data.xfrc_applied[self.ball_body] = self._wrench()
        if (self.hidden.restitution is None and not self.hidden.soft_walls) or not self.near_wall():
            mujoco.mj_step(self.model, self.data, nstep=CONTROL_STEPS)
            return
        for _ in range(CONTROL_STEPS):
            mujoco.mj_step(self.model, self.data)
            normal = self._wall_contact_normal()
            if normal is not None:
                self._wall_normal = normal
            elif self._wall_normal is not None:
                # The nominal bounce has just ended: rescale its normal speed to the hidden restitution there.
                n = self._wall_normal
                x, y = float(self.data.qpos[0]), float(self.data.qpos[1])
                e = self.hidden.restitution_at(wall_at(x, y, (self.half[0], self.half[1])), x, y)
                if e is not None:
                    v = self.data.qvel[:3]
                    vn = float(np.dot(v, n))
                    v += (e / self.nominal_restitution - 1.0) * vn * n
                    self.data.qvel[:3] = v
                self._wall_normal = None

    def off_field(self) -> bool:
        x, y = self.data.qpos[0], self.data.qpos[1]
        return abs(y) > self.half[1] or abs(x) > self.half[0] + 0.01

    def speed(self) -> float:
        return float(np.hypot(*self.data.qvel[:2]))

    def roll(self, duration: float, sample_dt: float = 1e-3) -> tuple[np.ndarray, np.ndarray]:
        """Step for up to `duration`; returns times since the roll began and ball positions (x, y, z).

        Ends early when the ball stops or leaves the field (through a goal mouth).
        """
        steps = max(1, int(round(sample_dt / (CONTROL_STEPS * self.model.opt.timestep))))
        times, positions = [0.0], [self.data.qpos[:3].copy()]
        t0 = self.data.time
        while self.data.time - t0 < duration:
            for _ in range(steps):
                self.step_block()
            times.append(self.data.time - t0)
            positions.append(self.data.qpos[:3].copy())
            if self.off_field() or self.speed() < 0.01:
                break
        return np.array(times), np.array(positions)


def predict_from(hidden: HiddenEffects, states: np.ndarray, horizons: Sequence[float]) -> np.ndarray:
    """Positions (n, H, 2) the hidden table gives from rolling states (x, y, vx, vy) after each horizon."""
    table = HiddenTable(hidden)
    out = np.full((len(states), len(horizons), 2), np.nan)
    for i, (x, y, vx, vy) in enumerate(states):
        table.reset((x, y), (vx, vy))
        times, positions = table.roll(max(horizons) + 0.002)
        for j, h in enumerate(horizons):
            out[i, j] = (np.interp(h, times, positions[:, 0]), np.interp(h, times, positions[:, 1]))
    return out


@dataclass
class Recording:
    t: np.ndarray  # s, detection stamps
    position: np.ndarray  # (N, 3) measured ball centre, table frame
    truth_t: np.ndarray
    truth_position: np.ndarray
    launches: list[tuple[float, float, float, float, float]]  # (t, x, y, vx, vy)


def random_launch(rng: np.random.Generator, half: np.ndarray, margin: float = 0.05,
                  speed_range=(0.3, 3.0)) -> tuple[np.ndarray, np.ndarray]:
    position = rng.uniform(-half + margin, half - margin)
    angle = rng.uniform(0, 2 * np.pi)
    speed = rng.uniform(*speed_range)
    return position, speed * np.array([np.cos(angle), np.sin(angle)])


def generate(effects: Sequence[dict], duration: float = 60.0, seed: int = 0, fps: float = 120.0,
             noise: float = 0.0015, dropout: float = 0.05, params: dict | None = None,
             progress: bool = False, shapes: Sequence[SurfaceShape | WallSegment] = ()) -> Recording:
    """Hand-launched rolls for `duration` seconds of recording (gaps where the ball is picked up), on a table
    with the hidden `effects` (the contract's vocabulary) and `shapes` of its surface (outside it)."""
    rng = np.random.default_rng(seed)
    hidden = HiddenEffects.from_effects(effects)
    hidden.shapes = [s for s in shapes if isinstance(s, SurfaceShape)]
    hidden.soft_walls = [s for s in shapes if isinstance(s, WallSegment)]
    table = HiddenTable(hidden, params)
    t_all, p_all, launches = [], [], []
    clock = 0.0
    bar = None
    if progress:
        bar = tqdm(total=round(duration), unit="s", desc="generating", file=sys.stderr)
    while clock < duration:
        position, velocity = random_launch(rng, table.half)
        table.reset(position, velocity)
        launches.append((clock, *position, *velocity))
        roll_time = min(rng.uniform(3.0, 8.0), duration - clock)
        times, positions = table.roll(roll_time)
        t_all.append(clock + times)
        p_all.append(positions)
        end = clock + times[-1]
        gap = rng.uniform(0.4, 1.0)  # the ball is picked up and placed for the next launch
        if bar is not None:
            bar.update(round(min(end + gap, duration)) - round(clock))
        clock = end + gap
    if bar is not None:
        bar.close()
    truth_t = np.concatenate(t_all)
    truth_p = np.concatenate(p_all)
    frames = np.arange(0.0, duration, 1.0 / fps)
    keep, measured = [], []
    for times, positions in zip(t_all, p_all):
        inside = frames[(frames >= times[0]) & (frames <= times[-1])]
        if inside.size == 0:
            continue
        xyz = np.stack([np.interp(inside, times, positions[:, k]) for k in range(3)], axis=1)
        keep.append(inside)
        measured.append(xyz)
    t = np.concatenate(keep)
    p = np.concatenate(measured)
    p[:, :2] += rng.normal(0.0, noise, size=(len(t), 2))
    p[:, 2] = table.radius  # a camera tracker reports the ball-centre plane
    visible = rng.random(len(t)) >= dropout
    return Recording(t[visible], p[visible], truth_t, truth_p, launches)


def write_bag(recording: Recording, path: str | Path) -> None:
    with BagWriter(path) as writer:
        write_ball_detections(writer, recording.t, recording.position)


def random_effect(name: str, rng: np.random.Generator, nominal_rolling: float = 0.15,
                  geometry: TableGeometry | None = None) -> dict:
    """One effect with a magnitude drawn from the acceptance ranges of the calibration issue.

    A dent lies wholly on the field of `geometry` (the regulation table's by default).
    """
    if name == "table_tilt":
        slope, angle = rng.uniform(0.002, 0.01), rng.uniform(0, 2 * np.pi)
        return {"name": name, "params": {"slope_x": slope * math.cos(angle), "slope_y": slope * math.sin(angle)}}
    if name == "rolling_resistance":
        factor = rng.uniform(0.5, 3.0)
        while abs(factor - 1.0) < 0.15:  # the range includes 1x, which is no effect at all
            factor = rng.uniform(0.5, 3.0)
        return {"name": name, "params": {"deceleration": nominal_rolling * factor}}
    if name == "viscous_damping":
        return {"name": name, "params": {"rate": rng.uniform(0.05, 0.3)}}
    if name == "air_drag":
        return {"name": name, "params": {"coefficient": rng.uniform(0.02, 0.1)}}
    if name == "surface_dent":
        geometry = geometry if geometry is not None else TableGeometry.nominal()
        hx, hy = geometry.half_width, geometry.half_length
        radius = rng.uniform(0.05, 0.15)
        x = rng.uniform(-hx + radius, hx - radius) if radius < hx else 0.0  # a dent wider than the field sits centred
        y = rng.uniform(-hy + radius, hy - radius)
        return {"name": name, "params": {"x": x, "y": y, "radius": radius, "depth": rng.uniform(0.001, 0.004)}}
    if name == "wall_restitution":
        e = rng.uniform(0.4, 0.9)
        while abs(e - 0.75) < 0.06:  # too close to the nominal 0.75 to be a different table
            e = rng.uniform(0.4, 0.9)
        return {"name": name, "params": {"coefficient": e}}
    raise EffectError(f"unknown effect `{name}`")


SELECTOR_KEYS = ("team", "rod", "axis", "wall")  # effect parameters that are names, not numbers


def parse_effect(text: str) -> dict:
    """`name:key=value,key=value` -> effect dict (team, rod, axis and wall take names, the rest numbers)."""
    name, _, rest = text.partition(":")
    params = {}
    for item in filter(None, rest.split(",")):
        key, _, value = item.partition("=")
        key = key.strip()
        if key in SELECTOR_KEYS:
            params[key] = value.strip()
            continue
        try:
            params[key] = float(value)
        except ValueError:
            raise argparse.ArgumentTypeError(f"effect parameter `{item}` is not key=number") from None
    if name not in MODEL_EFFECT_NAMES + games.CAMERA_EFFECTS:
        raise argparse.ArgumentTypeError(f"unknown effect `{name}` (known: {', '.join(MODEL_EFFECT_NAMES + games.CAMERA_EFFECTS)})")
    return {"name": name, "params": params}


_parse_effect = parse_effect  # the former name


def main(argv: Sequence[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="generate_measured",
        description=(
            "Write a synthetic 'measured' bag (/ball/detection, 120 fps, camera-like noise and dropouts) "
            "of hand-launched rolls on a table with hidden effects. The effects are injected as forces "
            "and bounce changes on the nominal model, not the way `calibrate` models them."),
        epilog=(
            "Examples:\n"
            "  ros2 run foos_calibration generate_measured out/tilt_bag --effect table_tilt:slope_x=0.005,slope_y=0\n"
            "  ros2 run foos_calibration generate_measured out/rand_bag --random 2 --seed 7 --truth out/truth.json\n"
            "  ros2 run foos_calibration generate_measured out/game --game --duration 90 --effect rod_latency:delay=0.03 \\\n"
            "      --effect rod_speed_limit:slide=1.5,team=home,rod=attack"),
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument("bag", help="output bag directory (must not exist)")
    parser.add_argument("--game", action="store_true",
                        help="record a game instead (both teams' simple players, /joint_states and the commands too); "
                             "it hides drive effects (rod_latency, rod_speed_limit, rod_acceleration_limit) and the table effects "
                             "but wall_restitution")
    games.add_arguments(parser)
    parser.add_argument("--effect", action="append", type=parse_effect, default=[],
                        help="hidden effect NAME:key=value,... in the contract's vocabulary (repeatable)")
    parser.add_argument("--shape", action="append", type=_shape_argument, default=[],
                        help="a shape of the table outside the contract's vocabulary (free rolls, repeatable): "
                             "bowl:depth=D, saddle:amplitude=A, ramp:corner=+x-y,rise=R,size=S (m) or "
                             "soft_wall:wall=side_pos_x,from=A,to=B,coefficient=E (a stretch of one wall)")
    parser.add_argument("--random", type=int, default=0, metavar="N",
                        help="hide N effects drawn at random (names and magnitudes) instead")
    parser.add_argument("--duration", type=float, default=60.0, help="seconds of recording (default 60)")
    parser.add_argument("--seed", type=int, default=0, help="random seed: launches, noise, dropouts, random effects")
    parser.add_argument("--noise", type=float, default=0.0015, help="detection noise std, m (default 0.0015)")
    parser.add_argument("--dropout", type=float, default=0.05, help="probability a frame has no detection (default 0.05)")
    parser.add_argument("--fps", type=float, default=120.0, help="camera frame rate (default 120)")
    parser.add_argument("--truth", help="also write the hidden effects to this JSON file (for tests and benchmarks)")
    args = parser.parse_args(argv)
    try:
        if not (args.duration > 0 and args.fps > 0 and args.noise >= 0 and 0 <= args.dropout < 1):
            raise ValueError("need duration > 0, fps > 0, noise >= 0 and 0 <= dropout < 1")
        if Path(args.bag).exists():
            raise ValueError(f"{args.bag} exists already; choose another name or delete it")
        effects = list(args.effect)
        if args.game:
            if args.random:
                rng = np.random.default_rng(args.seed + 1_000_003)
                names = rng.choice(games.DRIVE_EFFECTS, size=min(args.random, len(games.DRIVE_EFFECTS)), replace=False)
                effects = [games.random_drive_effect(str(n), rng) for n in names]
            options, style = games.options_from(args), None
            if args.style is not None:
                style = game_styles.draw(args.seed, args.style)
                options = replace(options, fps=style.fps, encoder_rate=style.encoder_rate)
            game = games.generate_game(args.bag, effects, options, style=style)
            if style is not None:
                game_styles.write_style(style, args.bag)
            if args.truth:
                Path(args.truth).write_text(json.dumps({"effects": effects, "seed": args.seed,
                                                        **({"style": style.as_dict()} if style else {})}, indent=2))
            print(games.describe(game, args.bag))
            if style is not None:
                print(style.describe())
            return 0
        if args.style is not None:
            raise ValueError("--style is for games: add --game")
        if args.camera_only:
            raise ValueError("--camera-only is for games (free rolls have the camera alone already): add --game")
        if args.game and args.shape:
            raise ValueError("--shape is hidden in free rolls only (leave out --game)")
        if any(e["name"] in games.DRIVE_EFFECTS for e in effects):  # a free roll has no drives to hide them in
            raise ValueError("drive effects (rod_*) are hidden in games: add --game")
        if any(e["name"] in games.CAMERA_EFFECTS for e in effects):  # found against the encoders' clock
            raise ValueError("camera_latency is hidden in games (against the joint states' clock): add --game")
        if any(e["name"] in games.FIGURE_EFFECTS for e in effects):  # a free roll has the rods lifted
            raise ValueError("figure_restitution is hidden in games (free rolls never meet a figure): add --game")
        if args.random:
            rng = np.random.default_rng(args.seed + 1_000_003)
            names = rng.choice([n for n in EFFECT_NAMES], size=min(args.random, len(EFFECT_NAMES)), replace=False)
            effects = [random_effect(str(n), rng) for n in names]
        HiddenEffects.from_effects(effects)
        recording = generate(effects, args.duration, args.seed, args.fps, args.noise, args.dropout, progress=True,
                             shapes=args.shape)
        write_bag(recording, args.bag)
        if args.truth:
            shapes = [{"type": type(shape).__name__, **asdict(shape)} for shape in args.shape]
            Path(args.truth).write_text(json.dumps({"effects": effects, "seed": args.seed, "shapes": shapes}, indent=2))
    except (ValueError, KeyError, OSError, games.GameError, game_styles.StyleError) as error:
        print(f"generate_measured: {str(error).splitlines()[0] if str(error) else type(error).__name__}", file=sys.stderr)
        return 2
    except Exception as error:  # BagError and friends: one line, no traceback
        print(f"generate_measured: {error}", file=sys.stderr)
        return 2
    print(f"wrote {args.bag}: {len(recording.t)} detections over {args.duration:.0f} s, "
          f"{len(recording.launches)} launches; hidden effects are not in the bag")
    return 0


def _shape_argument(text: str) -> SurfaceShape | WallSegment:
    try:
        return parse_shape(text)
    except ShapeError as error:
        raise argparse.ArgumentTypeError(str(error)) from None


if __name__ == "__main__":
    sys.exit(main())
