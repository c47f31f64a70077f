"""Train the still finder's ball verifier (detection.ball_verifier) on the simulated camera's renders, and only them.

    ./scripts/train_ball_verifier      # the shipped weights: 50 scenes x 5 frames, seed 0, about 18 minutes on 2 cores
    ./scripts/train_ball_verifier --scenes 8 --out /tmp/v.npz   # a quick try

The data: SCENES scenes of foos_sim's camera (foos_sim.camera.render), each drawn with the seed: the overhead or the
oblique camera, zoomed so the ball is 10-30 px across at the finder's work width, a felt of green, blue, black or pale
grey-blue, two teams of random colours (white, yellow and black among them: figures of the ball's colour), a ball of
white, yellow, yellow-green, orange or cork, the lights dimmed or brightened. FRAMES frames per scene pose the rods at
random (feet swung, figures slid) and put the ball anywhere on the field, half the time just beside a rod, in its
figures' shade or partly under a foot. Each frame is then spoiled as real footage is: painted lines, a centre circle
and spots on the felt (the spots are the ball's size: a flat white disc is no ball), a broadcast overlay, flicker,
camera shake (motion blur), lower resolution, sensor noise and JPEG compression.

The still finder (StillBallFinder.find) runs on each spoiled frame, as it would on real footage. Positives: patches
on the true ball (jittered by up to a third of a radius, its scale by 15 %) where at least 35 % of it is in view, and
the finder's candidates within half a radius of it. Negatives: the finder's own candidates more than two radii from the
ball (its hard cases: lines, spots, socks, heads, glints, walls) and random points of the field. The net is trained
with torch on the CPU (flips, turns, colour gains and noise on the patches), the last scenes held out to report how it
does, and its weights saved as an .npz that BallVerifier runs in numpy. No real footage is read.
"""
from __future__ import annotations

import argparse
import math
import sys
import time
import xml.etree.ElementTree as ET
from pathlib import Path

import cv2
import numpy as np
from tqdm import tqdm

from foos_core.camera_model import load_camera
from foos_core.markers import load_markers
from foos_core.names import JOINT_NAMES
from foos_core.table_geometry import TableGeometry
from foos_sim.camera.render import RenderOptions, SceneRenderer
from foos_sim.camera.scene import set_team_colour
from foos_sim.model_builder import build_mjcf
from foos_sim.simulation import TableSimulation

from .detection.ball_verifier import DEFAULT_WEIGHTS, PATCH, BallVerifier, normalise, raw_patches
from .detection.still_ball import WORK_WIDTH, StillBallFinder
from .field_bench import SIM_FELT_RGB

BALLS = {  # RGB, 0-1
    "white": (0.95, 0.95, 0.92), "yellow": (0.95, 0.80, 0.10), "yellow-green": (0.78, 0.90, 0.25),
    "orange": (0.98, 0.45, 0.05), "cork": (0.80, 0.64, 0.44),
}
FELTS = {"green": (0.10, 0.45, 0.18), "dark green": (0.05, 0.28, 0.10), "blue": (0.10, 0.22, 0.55),
         "black": (0.07, 0.07, 0.08), "grey-blue": (0.45, 0.52, 0.58)}
TEAMS = {"red": (0.80, 0.10, 0.10), "blue": (0.10, 0.20, 0.80), "black": (0.08, 0.08, 0.08),
         "green": (0.15, 0.55, 0.20), "yellow": (0.95, 0.85, 0.15), "white": (0.92, 0.92, 0.90),
         "grey": (0.55, 0.55, 0.55), "orange": (0.95, 0.45, 0.10)}
BALL_PX = (10.0, 30.0)  # the ball's diameter at the finder's work width
MIN_VISIBLE = 0.35  # of the ball's disc in view: a positive; less, and its candidates are neither
JITTERS = 6  # positive patches per ball, jittered
RANDOM_NEGATIVES = 12  # random points of the field per frame
HIDDEN = 32  # units of the hidden layer


def with_round_heads(mjcf: str, radius: float) -> str:
    """The table's MJCF with a sphere of the given radius on top of each figure's body, in its team's material: real
    figures have a round head about the ball's size, which an overhead camera sees as a lit disc (the simulated
    figures are boxes). Only for rendering: the spheres are massless to the eye and collide with nothing."""
    root = ET.fromstring(mjcf)
    for body in root.iter("body"):
        for geom in list(body.findall("geom")):
            name = geom.get("name", "")
            if "_figure" not in name or not name.endswith("_body"):
                continue
            x, y, z = (float(v) for v in geom.get("pos").split())
            top = z + float(geom.get("size").split()[2])
            head = ET.SubElement(body, "geom", name=name[:-5] + "_head", type="sphere", size=f"{radius:.4f}",
                                 pos=f"{x:.5f} {y:.5f} {top - 0.4 * radius:.5f}", material=geom.get("material"),
                                 contype="0", conaffinity="0", mass="0.0001")
            head.tail = geom.tail
    return ET.tostring(root, encoding="unicode")


def _jitter(rgb, rng, amount=0.05):
    return tuple(float(v) for v in np.clip(np.asarray(rgb) + rng.uniform(-amount, amount, 3), 0, 1))


def make_scene(rng: np.random.Generator, params_file=None, round_heads: bool = False) -> tuple[SceneRenderer, str, list]:
    name = "overhead" if rng.random() < 0.7 else "oblique"
    camera = load_camera(name).with_(width=1280, height=720)
    table = TableGeometry.of(params_file)
    # Zoom so the ball is BALL_PX wide at the finder's work width (1280: the renders' own), at the field's middle.
    focal = camera.camera_matrix()[0, 0]
    depth = float(camera.depth(np.array([[0.0, 0.0, table.ball_radius]]))[0])
    now = 2 * focal * table.ball_radius / depth * WORK_WIDTH / camera.width
    want = rng.uniform(*BALL_PX)
    half = math.radians(camera.fovy) / 2
    fovy = math.degrees(2 * math.atan(math.tan(half) * min(1.0, now / want)))
    # A zoomed camera looks at a part of the table, as a broadcast camera does; the felt must still fill its middle.
    reach = 1.0 - fovy / camera.fovy
    look = (rng.uniform(-0.25, 0.25) * reach, rng.uniform(-0.45, 0.45) * reach, 0.0)
    camera = camera.with_(fovy=fovy, look_at=look if name == "overhead" else None)
    teams = rng.choice(list(TEAMS), 2, replace=False)
    ball = rng.choice(list(BALLS))
    felt = rng.choice(list(FELTS))
    options = RenderOptions(camera=camera, ball_colour=_jitter(BALLS[ball], rng), noise=float(rng.uniform(0.5, 4.0)),
                            lighting=float(rng.uniform(0.6, 1.5)), visibility=True, shadows=True,
                            seed=int(rng.integers(1 << 30)))
    felt_rgb = " ".join(f"{c:.3f}" for c in np.clip(np.asarray(FELTS[felt]) * rng.uniform(0.85, 1.15, 3), 0, 1))
    mjcf = build_mjcf(params_file).replace(SIM_FELT_RGB, felt_rgb)
    if round_heads and rng.random() < 0.7:  # only then: the shipped weights' run draws nothing here
        mjcf = with_round_heads(mjcf, table.ball_radius * rng.uniform(0.9, 1.3))
    renderer = SceneRenderer(mjcf, load_markers(), options)
    team_rgb = [_jitter(TEAMS[colour], rng) for colour in teams]
    for team, rgb in zip(("home", "away"), team_rgb):
        set_team_colour(renderer.model, team, rgb)
    return renderer, f"{name} fovy {fovy:.0f} ball {ball} felt {felt} teams {teams[0]}/{teams[1]}", team_rgb


def pose(rng: np.random.Generator, table: TableGeometry) -> tuple[np.ndarray, tuple[float, float]]:
    """16 joint positions (slides and turns) and a ball position: half the time just beside a rod."""
    joints = np.zeros(len(JOINT_NAMES))
    for i, name in enumerate(JOINT_NAMES):
        if name.endswith("slide"):
            joints[i] = rng.uniform(-0.08, 0.08)
        else:
            joints[i] = rng.choice([rng.normal(0, 0.35), rng.uniform(-1.6, 1.6)])
    x = rng.uniform(-table.half_width + table.ball_radius, table.half_width - table.ball_radius)
    if rng.random() < 0.5:
        rod_y = rng.choice(list(table.rod_y.values()))
        y = rod_y + rng.choice([-1, 1]) * rng.uniform(0.01, 0.05)
    else:
        y = rng.uniform(-table.half_length + table.ball_radius, table.half_length - table.ball_radius)
    return joints, (float(x), float(y))


HEAD_Z = 0.10  # m: the middle of a figure's head over the surface (rod axis 0.078 m, head 0.04 m above it)


def draw_heads(image: np.ndarray, camera, table: TableGeometry, team_rgb: list, ball_px: float,
               rng: np.random.Generator) -> None:
    """Round, lit figure heads on the rods (the simulated figures are boxes; real ones have a round head about the
    ball's size, seen from above a lit disc on its rod: the commonest rival of a ball in real footage). Drawn in
    place, in the teams' colours, each a shaded disc with a highlight, centred on a rod's line."""
    for _ in range(rng.integers(0, 8)):
        rod_y = float(rng.choice(list(table.rod_y.values())))
        centre = np.array([[rng.uniform(-0.3, 0.3), rod_y, HEAD_Z]])
        u, v = camera.project(centre)[0]
        depth = float(camera.depth(centre)[0])
        r = camera.camera_matrix()[0, 0] * table.ball_radius / depth * rng.uniform(0.8, 1.2)
        n = int(math.ceil(r)) + 2
        x0, y0 = int(round(u)) - n, int(round(v)) - n
        if x0 < 0 or y0 < 0 or x0 + 2 * n + 1 > image.shape[1] or y0 + 2 * n + 1 > image.shape[0]:
            continue
        yy, xx = np.mgrid[-n:n + 1, -n:n + 1] + (np.array([y0, x0]) - np.array([v, u]))[:, None, None] + n
        d = np.hypot(xx, yy) / r
        inside = np.clip((1.0 - d) * r + 0.5, 0, 1)  # anti-aliased edge
        lx, ly = rng.uniform(-0.5, 0.5, 2)
        shade = 0.45 + 0.55 * np.sqrt(np.clip(1 - d ** 2, 0, 1))
        glint = np.exp(-(((xx / r - lx) ** 2 + (yy / r - ly) ** 2) / 0.04)) * rng.uniform(0.2, 0.8)
        bgr = np.array(team_rgb[int(rng.integers(len(team_rgb)))][::-1]) * 255
        head = np.clip(bgr * shade[..., None] + 255 * glint[..., None], 0, 255)
        window = image[y0:y0 + 2 * n + 1, x0:x0 + 2 * n + 1].astype(np.float32)
        image[y0:y0 + 2 * n + 1, x0:x0 + 2 * n + 1] = (window * (1 - inside[..., None])
                                                       + head * inside[..., None]).astype(np.uint8)


def spoil(image: np.ndarray, ball_px: float, rng: np.random.Generator) -> np.ndarray:
    """What real footage does to a frame: painted lines and spots on the felt, an overlay, flicker, shake, lower
    resolution, noise and JPEG."""
    h, w = image.shape[:2]
    out = image.copy()
    if rng.random() < 0.7:
        painted = out.copy()
        white = tuple(int(v) for v in rng.uniform(200, 255, 3))
        thick = max(1, int(round(rng.uniform(0.2, 0.6) * ball_px)))
        for _ in range(rng.integers(1, 5)):
            p0 = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
            p1 = (int(rng.uniform(0, w)), int(rng.uniform(0, h)))
            cv2.line(painted, p0, p1, white, thick, cv2.LINE_AA)
        if rng.random() < 0.5:
            cv2.circle(painted, (int(rng.uniform(0.3, 0.7) * w), int(rng.uniform(0.3, 0.7) * h)),
                       int(rng.uniform(4, 12) * ball_px), white, thick, cv2.LINE_AA)
        for _ in range(rng.integers(0, 4)):  # spots of the ball's size: flat, no shading
            cv2.circle(painted, (int(rng.uniform(0.2, 0.8) * w), int(rng.uniform(0.2, 0.8) * h)),
                       max(2, int(rng.uniform(0.35, 0.6) * ball_px)), white, -1, cv2.LINE_AA)
        # Paint lies on the felt only: figures, rods and the ball stay over it.
        lab = cv2.cvtColor(out, cv2.COLOR_BGR2Lab).astype(np.int16)
        centre = lab[h // 3:2 * h // 3, w // 3:2 * w // 3].reshape(-1, 3)
        felt_ab = np.median(centre[:, 1:], axis=0)
        felt = np.all(np.abs(lab[..., 1:] - felt_ab) <= 10, axis=2)
        out[felt] = painted[felt]
    if rng.random() < 0.3:
        x0, y0 = int(rng.uniform(0, 0.7) * w), int(rng.choice([rng.uniform(0, 0.1), rng.uniform(0.8, 0.9)]) * h)
        colour = tuple(int(v) for v in rng.uniform(0, 255, 3))
        cv2.rectangle(out, (x0, y0), (x0 + int(0.3 * w), y0 + int(0.08 * h)), colour, -1)
        cv2.putText(out, "LIVE 2 : 1", (x0 + 10, y0 + int(0.06 * h)), cv2.FONT_HERSHEY_SIMPLEX, 1.2,
                    tuple(255 - c for c in colour), 2, cv2.LINE_AA)
    out = out.astype(np.float32) * rng.uniform(0.75, 1.25)
    if rng.random() < 0.3:  # flicker bands of a rolling shutter under mains light
        rows = 1 + 0.1 * np.sin(np.arange(h) / h * rng.uniform(2, 12) * math.pi + rng.uniform(0, 6))
        out *= rows[:, None, None]
    out = np.clip(out, 0, 255).astype(np.uint8)
    if rng.random() < 0.3:
        length = int(rng.integers(3, 12))
        kernel = np.zeros((length, length), np.float32)
        kernel[length // 2] = 1.0 / length
        turn = cv2.getRotationMatrix2D(((length - 1) / 2, (length - 1) / 2), rng.uniform(0, 180), 1.0)
        kernel = cv2.warpAffine(kernel, turn, (length, length))
        out = cv2.filter2D(out, -1, kernel / max(kernel.sum(), 1e-6))
    if rng.random() < 0.3:
        f = rng.uniform(0.5, 0.8)
        out = cv2.resize(cv2.resize(out, (int(w * f), int(h * f)), interpolation=cv2.INTER_AREA), (w, h))
    out = np.clip(out.astype(np.float32) + rng.normal(0, rng.uniform(0, 4), out.shape), 0, 255).astype(np.uint8)
    if rng.random() < 0.8:
        ok, data = cv2.imencode(".jpg", out, [cv2.IMWRITE_JPEG_QUALITY, int(rng.uniform(25, 90))])
        out = cv2.imdecode(data, cv2.IMREAD_COLOR)
    return out


def frame_samples(image: np.ndarray, ball_uv, visible: float, finder: StillBallFinder,
                  rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray]:
    """(patches (N, P, P, 3) uint8, labels (N,)) of one spoiled frame; empty when the finder finds no field."""
    field, candidates = finder.find(image)
    if field is None:
        return np.zeros((0, PATCH, PATCH, 3), np.uint8), np.zeros(0, np.float32)
    r = field.ball_radius_px
    patches, labels = [], []
    u0, v0 = ball_uv
    if visible >= MIN_VISIBLE:
        for _ in range(JITTERS):
            angle, reach = rng.uniform(0, 2 * math.pi), r * rng.uniform(0, 0.33)
            centre = (u0 + reach * math.cos(angle), v0 + reach * math.sin(angle))
            patches.append(raw_patches(image, [centre], r * rng.uniform(0.85, 1.15)))
            labels.append(1.0)
    # The candidates' and the random points' patches share the field's radius: one raw_patches call each (it smooths
    # the whole frame first when it shrinks it), in the order they are labelled.
    centres = []
    for c in candidates:
        d = math.hypot(c.u - u0, c.v - v0)
        if d <= 0.5 * r and visible >= MIN_VISIBLE:
            centres.append((c.u, c.v))
            labels.append(1.0)
        elif d > 2 * r:
            centres.append((c.u, c.v))
            labels.append(0.0)
    inside = cv2.boundingRect(field.outline.astype(np.float32))
    for _ in range(RANDOM_NEGATIVES):
        u = inside[0] + rng.uniform(0, inside[2])
        v = inside[1] + rng.uniform(0, inside[3])
        if math.hypot(u - u0, v - v0) > 2 * r:
            centres.append((u, v))
            labels.append(0.0)
    patches.append(raw_patches(image, centres, r))
    return np.concatenate(patches), np.array(labels, np.float32)


def generate(scenes: int, frames: int, seed: int, params_file=None, quiet=False,
             round_heads: bool = False) -> dict[str, np.ndarray]:
    rng = np.random.default_rng(seed)
    table = TableGeometry.of(params_file)
    finder = StillBallFinder(params_file)
    all_patches, all_labels, scene_of = [], [], []
    bar = tqdm(total=scenes * frames, desc="rendering", unit="frame", disable=quiet)
    for s in range(scenes):
        renderer, what, team_rgb = make_scene(rng, params_file, round_heads)
        bar.set_postfix_str(what)
        try:
            for _ in range(frames):
                joints, ball = pose(rng, table)
                sim = TableSimulation(params_file)
                sim.reset(ball_position=ball, ball_velocity=(0.0, 0.0), joint_positions=joints)
                qpos = sim.data.qpos.copy()
                image = renderer.finish([renderer.render_rgb(qpos)])
                visible = renderer.visible_fraction(qpos)
                camera = renderer.camera
                centre = sim.ball_position()
                uv = camera.project(centre[None, :])[0]
                depth = float(camera.depth(centre[None, :])[0])
                ball_px = 2 * camera.camera_matrix()[0, 0] * table.ball_radius / depth
                if rng.random() < 0.6:
                    draw_heads(image, camera, table, team_rgb, ball_px, rng)
                image = spoil(image, ball_px, rng)
                p, y = frame_samples(image, uv, visible, finder, rng)
                all_patches.append(p)
                all_labels.append(y)
                scene_of.append(np.full(len(y), s, np.int32))
                bar.update(1)
        finally:
            renderer.close()
    bar.close()
    return {"patches": np.concatenate(all_patches), "labels": np.concatenate(all_labels),
            "scene": np.concatenate(scene_of)}


def augment(raw: np.ndarray, rng: np.random.Generator) -> np.ndarray:
    """Flips, quarter turns, per-channel gains and noise on (N, P, P, 3) uint8 patches; float32 (N, 3, P, P) out."""
    x = raw.astype(np.float32)
    if rng.random() < 0.5:
        x = x[:, :, ::-1]
    if rng.random() < 0.5:
        x = x[:, ::-1]
    x = np.rot90(x, int(rng.integers(4)), axes=(1, 2))
    x = x * rng.uniform(0.8, 1.2, (len(x), 1, 1, 3)) * rng.uniform(0.8, 1.2, (len(x), 1, 1, 1))
    x = x + rng.normal(0, rng.uniform(0, 4), x.shape)
    return normalise(np.clip(x, 0, 255))


def train(data: dict[str, np.ndarray], epochs: int, seed: int, quiet=False):
    import torch  # here: torch is for training only; the verifier runs in numpy
    from torch import nn  # the same: training only

    torch.manual_seed(seed)
    torch.set_num_threads(1)
    rng = np.random.default_rng(seed)
    scenes = int(data["scene"].max()) + 1
    held = data["scene"] >= scenes - max(1, scenes // 7)  # the last scenes: held out
    x_train, y_train = data["patches"][~held], data["labels"][~held]
    net = nn.Sequential(
        nn.Conv2d(3, 8, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
        nn.Conv2d(8, 16, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
        nn.Conv2d(16, 32, 3, padding=1), nn.ReLU(), nn.MaxPool2d(2),
        nn.Flatten(), nn.Linear(32 * (PATCH // 8) ** 2, HIDDEN), nn.ReLU(), nn.Linear(HIDDEN, 1))
    positives = max(1.0, float(y_train.sum()))
    loss_of = nn.BCEWithLogitsLoss(pos_weight=torch.tensor((len(y_train) - positives) / positives))
    optimiser = torch.optim.AdamW(net.parameters(), lr=3e-3, weight_decay=1e-4)
    schedule = torch.optim.lr_scheduler.OneCycleLR(optimiser, 3e-3, total_steps=epochs * (len(y_train) // 128 + 1))
    for _ in tqdm(range(epochs), desc="training", unit="epoch", disable=quiet):
        order = rng.permutation(len(y_train))
        for start in range(0, len(order), 128):
            batch = order[start:start + 128]
            xb = torch.from_numpy(np.ascontiguousarray(augment(x_train[batch], rng)))
            loss = loss_of(net(xb)[:, 0], torch.from_numpy(y_train[batch]))
            optimiser.zero_grad()
            loss.backward()
            optimiser.step()
            schedule.step()
    conv = [m for m in net if isinstance(m, nn.Conv2d)]
    fc = [m for m in net if isinstance(m, nn.Linear)]
    weights = {}
    for name, m in zip(("conv1", "conv2", "conv3", "fc1", "fc2"), conv + fc):
        weights[f"{name}.w"] = m.weight.detach().numpy().astype(np.float32)
        weights[f"{name}.b"] = m.bias.detach().numpy().astype(np.float32)
    return weights, held


def report(verifier: BallVerifier, data: dict[str, np.ndarray], held: np.ndarray) -> str:
    p = verifier.probability(normalise(data["patches"][held]))
    y = data["labels"][held] > 0.5
    if not y.any() or y.all():
        return "held-out scenes: too few to report"
    tp = np.count_nonzero(p[y] >= 0.5) / np.count_nonzero(y)
    fp = np.count_nonzero(p[~y] >= 0.5) / np.count_nonzero(~y)
    # The chance a random ball patch outscores a random other one (the ROC's area).
    order = np.argsort(p)
    ranks = np.empty(len(p))
    ranks[order] = np.arange(1, len(p) + 1)
    auc = (ranks[y].sum() - y.sum() * (y.sum() + 1) / 2) / (y.sum() * (~y).sum())
    return (f"held-out scenes: {np.count_nonzero(y)} ball and {np.count_nonzero(~y)} other patches; at 0.5, "
            f"{100 * tp:.1f} % of balls and {100 * fp:.2f} % of others pass; ROC area {auc:.4f}")


def main(argv=None) -> None:
    p = argparse.ArgumentParser(prog="train_ball_verifier", description=__doc__,
                                formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--scenes", type=int, default=50, help="rendered scenes (default 50)")
    p.add_argument("--frames", type=int, default=5, help="frames per scene (default 5)")
    p.add_argument("--epochs", type=int, default=12, help="passes over the patches (default 12)")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--out", default=str(DEFAULT_WEIGHTS), help="the weights file (default: the one foos_vision ships)")
    p.add_argument("--round-heads", action="store_true",
                   help="give 70 %% of the scenes' figures round heads (spheres in the MJCF; see the verifier log)")
    p.add_argument("--data", help="keep the patches here (.npz) and reuse them when the file exists")
    args = p.parse_args(argv)
    if args.scenes < 2 or args.frames < 1 or args.epochs < 1:
        print("train_ball_verifier: error: --scenes must be at least 2, --frames and --epochs at least 1",
              file=sys.stderr)
        sys.exit(2)
    started = time.time()
    if args.data and Path(args.data).exists():
        with np.load(args.data) as stored:
            data = {k: stored[k] for k in stored.files}
    else:
        data = generate(args.scenes, args.frames, args.seed, round_heads=args.round_heads)
        if args.data:
            np.savez_compressed(args.data, **data)
    print(f"{len(data['labels'])} patches, {int(data['labels'].sum())} of balls, from {args.scenes} scenes "
          f"({time.time() - started:.0f} s)")
    weights, held = train(data, args.epochs, args.seed)
    out = Path(args.out)
    out.parent.mkdir(parents=True, exist_ok=True)
    np.savez_compressed(out, **weights)
    print(report(BallVerifier(out), data, held))
    print(f"wrote {out} ({out.stat().st_size / 1024:.0f} KB) in {time.time() - started:.0f} s")


if __name__ == "__main__":
    main()
