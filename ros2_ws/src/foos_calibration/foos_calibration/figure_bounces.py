"""figure_restitution: the ball's bounces off figures in games, measured and checked on MuJoCo replays.

Each kink of the ball's path (figure_kinks) where a figure, posed from the joint states at the kink's time
(figure_contacts.FigureModel), touches the ball is a figure bounce. At the touch:
- the normal is the figure box's surface normal at the point nearest the ball centre (horizontal part; a
  touch whose normal is mostly vertical, a foot on top of the ball, is left out);
- the figure's velocity there is that material point's, posed at t +/- FIGURE_DT (finite differences of
  the pose);
- the ball's velocities before and after are the kink's two lines (figure_kinks).

The apparent coefficient of a bounce is -(v_after - v_figure).n / (v_before - v_figure).n. It is NOT the
contact's restitution: the rod gives way under the impact (its inertia and its servo), so against a
figure at rest the ball returns less than `figures: restitution` (about 0.4 for 0.5 on this model).
The coefficient is therefore fitted the way wall bounces are (bounces.py): every slow-figure bounce
(figure point slower than SLOW_FIGURE, ball approaching faster than MIN_APPROACH) is replayed on the fast
physics (TableSimulation, the whole table: rods posed and driven at the encoders' velocities, the ball
started from the line before the touch) for each restitution on GRID, and its squared error against the
detections through the touch is kept. Only windows whose error is a parabola over the grid count (PARABOLA: others
had another touch in them at some restitutions only). The coefficient is the median of the windows' own minima (a
spline through the grid each); it is named on held-out evidence (bounces alternating between two folds, each fold's fit scored
on the other, in detection-noise variances) and only when it differs materially from the nominal one.
"""
from __future__ import annotations

import copy
from dataclasses import dataclass, field

import numpy as np

from foos_core.names import AXES, JOINT_NAMES, TEAMS
from foos_sim.drive_profiles import drive_kind
from foos_sim.simulation import TableSimulation

from . import effect_gain
from .bounces import spline_at, spline_minimum
from .figure_contacts import FigureModel, JointTrack
from .figure_kinks import Kink

FIGURE_DT = 0.004  # s either side for the figure's velocity (the encoders sample every 4 ms)
TOUCH = 0.004  # m: a kink is a figure bounce when the ball is this close to a figure there
SLOW_FIGURE = 1.5  # m/s: a figure point slower than this (the replays drive the rods as measured)
MIN_APPROACH = 0.3  # m/s of the ball toward the figure, relative to it
MAX_VERTICAL = 0.5  # |n_z| above this: the figure met the ball from above or below
BEFORE, AFTER = 0.025, 0.05  # s of each replay window before and after the touch
GRID = np.round(np.arange(0.15, 0.951, 0.1), 3)
FINE_POINTS = 801  # where each window's spline minimum is read: 0.001 apart over GRID
MIN_BOUNCES = 8
MIN_EVIDENCE = 30.0
MIN_CHANGE = 0.08  # a coefficient closer than this to the nominal one is not named
REPLAY_FIT = 8.0  # times the noise: a window no restitution replays better than this had another touch
WINDOW_CAP = 3.0  # a window's error counts up to this many times its best
SENSITIVE = 1.5  # a window whose error changes less than this factor over the grid says nothing of the restitution
# With the touch alone in a window, the replayed path after it moves linearly with the returned speed, itself linear
# in the restitution: the window's error is a parabola over the grid. A window whose error strays from its least-squares
# parabola by more than this share of its rise over the grid (rms) had something else in it at some restitutions only
# (the ball sent on into a wall or another figure, a second touch of the foot), and its own best restitution is that
# touch's. Of 532 windows in 32 games (0.2-0.75 hidden), 329 stray under 0.03, 89 over 0.1 (calibration-2026-11-27-figure-restitution.md).
PARABOLA = 0.08


@dataclass
class FigureBounce:
    kink: Kink
    geom: str
    normal: np.ndarray  # (2,) horizontal, unit, from the figure toward the ball
    figure_velocity: np.ndarray  # (3,) of the figure's point nearest the ball
    approach: float  # m/s, the ball's normal speed toward the figure, relative to it
    apparent: float  # the returned share of it


@dataclass
class FigureRestitution:
    coefficient: float | None  # None: not named
    fitted: float
    evidence: dict
    block: dict  # report.json's `figure_bounces`
    effects: list[dict] = field(default_factory=list)


def _nearest_box(figures: FigureModel, xy: np.ndarray, q: np.ndarray) -> tuple[int, np.ndarray, np.ndarray]:
    """The figure geom nearest a ball at xy (on the field) for joint positions q (16,): its index, the nearest
    point of its box in the box's frame, and that point in the table frame."""
    centre, mat = figures.poses(q[None])
    ball = np.array([xy[0], xy[1], figures.ball_radius])
    local = np.einsum("gji,gj->gi", mat[0], ball[None] - centre[0])
    half = figures.geoms.half
    nearest_local = np.clip(local, -half, half)
    gaps = np.linalg.norm(local - nearest_local, axis=1)
    g = int(np.argmin(gaps))
    return g, nearest_local[g], centre[0, g] + mat[0, g] @ nearest_local[g]


def _point_at(figures: FigureModel, g: int, local: np.ndarray, q: np.ndarray) -> np.ndarray:
    centre, mat = figures.poses(q[None])
    return centre[0, g] + mat[0, g] @ local


def figure_bounces(kinks: list[Kink], figures: FigureModel, joints: JointTrack) -> list[FigureBounce]:
    """The kinks that are bounces off a figure, with their normal, figure velocity and apparent coefficient."""
    out = []
    for kink in kinks:
        q = joints.at(np.array([kink.t]))[0]
        if figures.distance(kink.xy[None], q[None])[0] > TOUCH:
            continue
        g, local, point = _nearest_box(figures, kink.xy, q)
        normal3 = np.array([kink.xy[0], kink.xy[1], figures.ball_radius]) - point
        if np.linalg.norm(normal3) < 1e-6:
            continue  # the ball centre inside a box: the poses and the ball disagree
        normal3 /= np.linalg.norm(normal3)
        if abs(normal3[2]) > MAX_VERTICAL:
            continue
        normal = normal3[:2] / np.linalg.norm(normal3[:2])
        ahead, behind = joints.at(np.array([kink.t + FIGURE_DT]))[0], joints.at(np.array([kink.t - FIGURE_DT]))[0]
        velocity = (_point_at(figures, g, local, ahead) - _point_at(figures, g, local, behind)) / (2 * FIGURE_DT)
        approach = -float(np.dot(kink.v_before - velocity[:2], normal))
        returned = float(np.dot(kink.v_after - velocity[:2], normal))
        if approach <= 0:
            continue
        out.append(FigureBounce(kink, figures.geoms.names[g], normal, velocity, approach, returned / approach))
    return out


def _slow(bounces: list[FigureBounce]) -> list[FigureBounce]:
    return [b for b in bounces if np.linalg.norm(b.figure_velocity) < SLOW_FIGURE and b.approach > MIN_APPROACH]


def _joint_velocity(joints: JointTrack, times: np.ndarray) -> np.ndarray:
    return (joints.at(times + FIGURE_DT) - joints.at(times - FIGURE_DT)) / (2 * FIGURE_DT)


def off_parabola(rss: np.ndarray, grid: np.ndarray = GRID) -> np.ndarray:
    """Each window's rms distance (in units of its best error) from its least-squares parabola over the grid, as a
    share of its rise over the grid (max / best - 1)."""
    relative = rss / rss.min(axis=1, keepdims=True)
    x = grid - grid.mean()
    design = np.stack([np.ones_like(x), x, x * x], axis=1)
    coefficients, *_ = np.linalg.lstsq(design, relative.T, rcond=None)
    stray = np.sqrt(np.mean((relative - (design @ coefficients).T) ** 2, axis=1))
    return stray / np.maximum(relative.max(axis=1) - 1.0, 1e-9)


def replay_errors(bounces: list[FigureBounce], t: np.ndarray, xy: np.ndarray, joints: JointTrack, params: dict,
                  grid: np.ndarray = GRID) -> tuple[np.ndarray, np.ndarray]:
    """Squared error (bounces, grid) of fast-physics replays through each bounce for each figure restitution,
    and the number of detections in each window."""
    rss = np.zeros((len(bounces), len(grid)))
    counts = np.zeros(len(bounces), dtype=int)
    for j, e in enumerate(grid):
        tree = copy.deepcopy(params)
        tree["figures"]["restitution"] = float(e)
        # The fast physics, whatever the base table runs: its impacts give each restitution exactly (the 20 kHz
        # reference's springs come within 0.03), at 1/25 of the steps.
        tree.setdefault("solver", {})["physics"] = "fast"
        sim = TableSimulation(params=_driven_as_measured(tree))
        dofs = np.array([sim.model.joint(name).dofadr[0] for name in JOINT_NAMES])
        limits = np.tile(sim.command_limits, len(TEAMS))
        for i, bounce in enumerate(bounces):
            k = bounce.kink
            start = k.t - BEFORE
            inside = (t >= start) & (t <= k.t + AFTER)
            counts[i] = int(inside.sum())
            sim.reset(ball_position=k.xy + k.v_before * (start - k.t), ball_velocity=k.v_before,
                      joint_positions=joints.at(np.array([start]))[0])
            sim.data.qvel[dofs] = _joint_velocity(joints, np.array([start]))[0]
            steps = int(np.ceil((BEFORE + AFTER) / sim.timestep)) + 1
            # The rods driven at the encoders' velocities, looked up for the whole window at once.
            drive = np.clip(_joint_velocity(joints, start + np.arange(steps) * sim.timestep), -limits, limits)
            times, path = [0.0], [sim.ball_position()[:2].copy()]
            for wanted in drive:
                for team_index, team in enumerate(TEAMS):
                    sim.set_command(team, wanted[team_index * 8:(team_index + 1) * 8])
                sim.step(1)
                times.append(sim.time)
                path.append(sim.ball_position()[:2].copy())
            times, path = np.array(times), np.array(path)
            local = t[inside] - start
            rss[i, j] = float(np.sum((np.interp(local, times, path[:, 0]) - xy[inside, 0]) ** 2
                                     + (np.interp(local, times, path[:, 1]) - xy[inside, 1]) ** 2))
    return rss, counts


# How much faster than the table's own the replays' jerk-limited generators may change a rod's velocity.
AS_MEASURED = 1000.0


def _driven_as_measured(tree: dict) -> dict:
    """The replay's table with drives that follow the encoders' velocities within a step. A robot table's jerk-limited
    generators would plan an S-curve to each one (9425 rad/s^2, 36650 rad/s^3: 40 ms to full acceleration) and leave
    the rods behind the measured ones; with limits AS_MEASURED times higher they keep their kind (a rod's give under an
    impact is the drive's) and track the encoders. The servos follow their command within about 3 ms as they are."""
    if drive_kind(tree) != "jerk_limited":
        return tree
    rods = tree["rods"]
    for axis in AXES:
        for limit in ("acceleration_limit", "jerk_limit"):
            rods[f"{axis}_{limit}"] = float(rods[f"{axis}_{limit}"]) * AS_MEASURED
    return tree


def find_figure_restitution(kinks: list[Kink], t: np.ndarray, xy: np.ndarray, figures: FigureModel, joints: JointTrack,
                            params: dict, noise: float) -> FigureRestitution:
    """figure_restitution from a game's figure bounces (see the module's docstring). `t` on the encoders'
    clock (a camera latency taken off), `params` the table the ball side starts from."""
    nominal = float(params["figures"]["restitution"])
    bounces = figure_bounces(kinks, figures, joints)
    slow = _slow(bounces)
    apparent = np.array([b.apparent for b in slow])
    block = {"kinks": len(kinks), "figure_bounces": len(bounces), "slow_figure_bounces": len(slow), "nominal": nominal,
             "apparent_median": round(float(np.median(apparent)), 3) if len(apparent) else None,
             "method": ("fast-physics replays (the whole table, rods posed and driven from /joint_states) through each bounce "
                        f"off a figure slower than {SLOW_FIGURE} m/s, for each restitution on a grid; folds of alternating bounces")}
    if len(slow) < MIN_BOUNCES:
        reason = f"only {len(slow)} bounces off slow figures (need {MIN_BOUNCES})"
        return FigureRestitution(None, nominal, {"reason": reason}, {**block, "named": False, "reason": reason})
    rss, counts = replay_errors(slow, t, xy, joints, params)
    sigma2 = max(noise, 1e-4) ** 2
    best = rss.min(axis=1)
    clean = (best <= (REPLAY_FIT**2) * 2 * sigma2 * np.maximum(counts, 1)) & (rss.max(axis=1) >= SENSITIVE * best)
    parabolic = off_parabola(rss) <= PARABOLA
    block["off_parabola"] = int((clean & ~parabolic).sum())
    clean &= parabolic
    # Each window's error in units of its own best replay's residual variance: a replay misses by more than the
    # noise (the rods follow the encoders only as their servos can), and a window must not weigh by its misfit.
    # Capped at WINDOW_CAP times its best, so that no single window decides.
    points = 2 * np.maximum(counts[clean], 1)
    rss = np.minimum(rss[clean] / (best[clean] / points)[:, None], WINDOW_CAP * points[:, None])
    block["replayed"], block["clean_replays"] = len(slow), int(clean.sum())
    if len(rss) < MIN_BOUNCES:
        reason = f"only {len(rss)} bounces replayed cleanly (need {MIN_BOUNCES})"
        return FigureRestitution(None, nominal, {"reason": reason}, {**block, "named": False, "reason": reason})
    total = rss.sum(axis=0)
    # The coefficient: the median of the windows' own best restitutions (robust to the few a replay gets wrong);
    # the held-out evidence: the other fold's capped error at it against the nominal one.
    own = np.array([spline_minimum(row, GRID, FINE_POINTS) for row in rss])
    fitted = float(np.median(own))
    folds = np.arange(len(rss)) % 2
    drops, fold_fits = [], []
    for k in (0, 1):
        e_k = float(np.median(own[folds == k]))
        test = rss[folds != k].sum(axis=0)
        fold_fits.append(e_k)
        drops.append(spline_at(test, nominal, GRID) - spline_at(test, e_k, GRID))
    rng = np.random.default_rng(0)
    boot = [float(np.median(own[rng.integers(0, len(own), len(own))])) for _ in range(500)]
    interval = [round(float(v), 3) for v in np.percentile(boot, [2.5, 97.5])]
    material = abs(fitted - nominal) >= MIN_CHANGE
    # The gain rule (effect_gain): the replays' RMS ball error over the bounces, each window's in units of its own best
    # replay's (as the evidence weighs them, capped), held out (each at the other fold's coefficient), without and with
    # the fitted restitution; each bounce its own stretch.
    per_point = rss / points[:, None]
    held = np.array([np.interp(fold_fits[1 - k], GRID, row) for row, k in zip(per_point, folds)])
    gain = {"what": "RMS over the bounces off slow figures of the replay's ball error, in units of each window's best "
                    "replay's error (1: every window at its best), each at the other fold's coefficient",
            **effect_gain.drop_interval(np.array([np.interp(nominal, GRID, row) for row in per_point]), held,
                                        np.arange(len(per_point)), weights=points.astype(float))}
    evidence = {
        "held_out_error_drop_noise_variances": round(float(sum(drops)), 1),
        "per_fold": [round(float(d), 1) for d in drops],
        "fold_coefficients": [round(float(e), 3) for e in fold_fits],
        "in_sample_error_drop_noise_variances": round(float(spline_at(total, nominal, GRID) - spline_at(total, fitted, GRID)), 1),
        "variance_unit": "each replay window's own best residual variance",
        "bounces": int(len(rss)),
        "ci95": interval,
        "material": bool(material),
        "gain": gain,
    }
    named = bool(sum(drops) >= MIN_EVIDENCE and min(drops) > 0 and material and effect_gain.excludes_zero(gain))
    if sum(drops) >= MIN_EVIDENCE and min(drops) > 0 and material and not named:
        evidence["reason"] = "no held-out gain: the drop's 95 % interval does not lie above zero"
    block.update({"named": named, "fitted": round(fitted, 3), "ci95": interval, "fold_coefficients": evidence["fold_coefficients"],
                  "held_out_drop_noise_variances": evidence["per_fold"]})
    effects = [{"name": "figure_restitution", "params": {"coefficient": round(fitted, 3)}, "evidence": evidence}] if named else []
    return FigureRestitution(round(fitted, 3) if named else None, fitted, evidence, block, effects)


def describe(effect: dict, nominal: float) -> str:
    """One plain sentence for report.md."""
    return (f"The figures return {effect['params']['coefficient']:.2f} of the ball's normal speed instead of the nominal "
            f"{nominal:.2f} (fitted on fast-physics replays of the bounces). Modelled by the parameter file's figures restitution.")
