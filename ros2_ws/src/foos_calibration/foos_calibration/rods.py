"""The rod drives from a game: rod_latency, rod_speed_limit and rod_acceleration_limit, by held-out evidence.

The model (foos_sim.drive_limits) shapes each drive's received commands: dead time, speed clip, rate
limit; the nominal servo then follows with its own acceleration limit (force / inertia) and lag
(inertia / gain). Each drive's measured /joint_states velocity is compared with that shaped velocity:

    v(t) = y(t - delay - lag),  y: the commands clipped to the speed limit, rate-limited at
                                   min(acceleration limit, force / inertia)

On the jerk-limited drives (params/robot_table.yaml, foos_sim.drive_profiles) y is the drives' own S-curve instead, at
min(acceleration limit, the drive's) and its jerk limit; the lag is half a fast physics step (DriveModel.lag).

y is exact for commands that hold between arrivals (a recurrence over the command times only), so a
model costs one pass over the commands, and every candidate value is a lane of the same arrays (lanes with
the same commands and limits share one recurrence).

Selection, per drive (each of the 16 is fitted alone; drives do not interact): every subset of the three
components is fitted by coordinate descent over grids on all samples and on each of two folds (stretches
of STRETCH seconds, alternating). A component is added (forward) when the held-out squared error drop it
brings (each fold predicted with the other fold's fit) exceeds MIN_EVIDENCE variances, no fold loses, and
its value is material. A drive that names a speed or acceleration limit with a latency (or none) other
than the common one is refitted with the common latency, and keeps its own only on held-out evidence
(_hold_common_latency: on one drive a dead time and a rate limit trade off). Then across drives: a
component named on most drives of an axis is one effect for all drives (the median value); a drive whose
own value differs materially from that, or a component named on few drives, gives a per-drive effect
(team, rod, and for the latency the axis).

The gain: joint positions 0.1 s and 0.25 s ahead (drive_prediction) from starts on each
fold, with the parameters fitted on the other fold, against the nominal drives: medians over starts and
drives with bootstrap 95 % intervals, slides in mm and rotations in degrees.
"""
from __future__ import annotations

import itertools
from dataclasses import dataclass, field
from typing import Callable

import numpy as np

from foos_core.names import COMMAND_SIZE, JOINT_NAMES, TEAMS
from foos_sim.drive_limits import DriveLimits, Servo, drive_limits_from_effects
from foos_sim.drive_profiles import ProfileLimits

from . import drive_gain, drive_prediction, drive_shaping
from .drive_shaping import shaped_velocity

COMPONENTS = ("latency", "speed", "acceleration")
EFFECT_OF = {"latency": "rod_latency", "speed": "rod_speed_limit", "acceleration": "rod_acceleration_limit"}
STRETCH = 4.0  # s: folds alternate stretches of this length
MIN_EVIDENCE = 30.0  # held-out squared-error drop, in noise (or residual) variances, to name a component
MIN_FOLD_SHARE = 0.05  # and neither fold may get worse by more than this share of the total (or 10)
MATERIAL_DELAY = 0.008  # s: less is within the servo model's own approximations (a 2 ms physics step)
MATERIAL_SPEED = 0.9  # a speed limit below this share of the highest speed the commands asked for
MATERIAL_ACCEL = 0.35  # an acceleration limit below this share of the servo's own (force / inertia)
# On the jerk-limited drives: below this share of the highest acceleration their nominal S-curves reach on the
# commands sent (a slide's peaks at 36-53 m/s^2 of its 104: the jerk limit, not the acceleration limit, binds).
MATERIAL_PROFILE_ACCEL = 0.9
DIFFERENT_DELAY = (0.008, 0.25)  # s and share: a drive's latency differs from the rest by more than both
DIFFERENT_RATIO = 1.25  # a drive's speed or acceleration limit differs from the rest by more than this factor
STOP_MARGIN = 0.01  # m: slide samples this close to a travel stop are left out (its soft limit holds the rod)
HORIZONS = (0.1, 0.25)
START_SPACING = 0.2  # s between prediction starts
SERVO_SETTLE = 10  # time constants before a start from which a servo's velocity is followed to it (e^-10 left)
# Coarse grids, each refined around its best value (REFINE points spanning one coarse step either side).
DELAY_GRID = np.arange(0.0, 0.1505, 0.006)  # s
SPEED_GRID = np.geomspace(0.2, 1.0, 12)  # shares of the drive's command limit (1: no limit)
# The jerk-limited drives' rotation limit is 314 rad/s, 8x the former servos' 40: the same step, from 0.02 (12
# points from 0.02, a coarser step, fitted a hidden 1.6 m/s slide limit 2.3 % low and named acceleration limits
# on four slides to make up for it).
PROFILE_SPEED_GRID = np.geomspace(0.02, 1.0, 28)
ACCEL_GRID = np.geomspace(0.01, 1.0, 16)  # shares of the servo's own acceleration (1: no limit)
REFINE = 9
# Joint states used for the fit: those nearest a FIT_RATE grid (all of them from slower encoders), whatever the encoder
# rate. The evidence is a sum over samples, so a fixed rate keeps MIN_EVIDENCE's meaning (it was set on every second
# sample of 250 Hz encoders: 125 Hz) and the fit's cost (lanes x samples) the same on 100 Hz and 1 kHz encoders.
FIT_RATE = 125.0  # Hz


class RodDataError(ValueError):
    """Joint states and commands that cannot identify the drives (say why in one line)."""


@dataclass
class DriveData:
    """One game's drive measurements: joint states (JOINT_NAMES columns) and both teams' commands."""

    t: np.ndarray  # (N,) s
    position: np.ndarray  # (N, 16)
    velocity: np.ndarray  # (N, 16)
    command_t: dict[str, np.ndarray]  # team -> (K,) arrival times
    commands: dict[str, np.ndarray]  # team -> (K, 8)


@dataclass
class DriveModel:
    """What the fitting needs to know about the nominal drives (JOINT_NAMES order)."""

    servo: Servo
    command_limits: np.ndarray  # (16,)
    travel: np.ndarray  # (16,) slide stops +/-, inf for rotations
    timestep: float  # the physics step the servo's implicit update is taken at
    profiles: ProfileLimits | None = None  # the jerk-limited drives' generators; None: servos on the command
    continuous: bool = False  # servos predicted by their own law in continuous time; False: as the fast physics steps them

    @property
    def servo_accel(self) -> np.ndarray:
        """The drive's own acceleration limit: its generator's, or its servo's (force / inertia)."""
        if self.profiles is not None:
            return self.profiles.acceleration
        return self.servo.force_limit / self.servo.inertia

    @property
    def lag(self) -> np.ndarray:
        if self.profiles is not None:
            # The rods follow their generators' setpoints; the fast physics moves a step at the setpoint of its
            # middle (foos_sim.drives.FollowingDrives), so its joint velocities trail the setpoint by half a step.
            return np.full(len(JOINT_NAMES), self.timestep / 2)
        return self.servo.inertia / self.servo.gain

    @property
    def jerk(self) -> np.ndarray | None:
        return None if self.profiles is None else self.profiles.jerk


@dataclass
class RodResult:
    effects: list[dict]
    block: dict  # report.json "rods"
    fold_limits: list[DriveLimits] = field(default_factory=list)
    refused: list[dict] = field(default_factory=list)  # effects the selection named that earned no held-out gain


# --- fitting one team's drives ---------------------------------------------------------------------
@dataclass
class _Team:
    """One team's 8 drives prepared for fitting: samples, masks, scales."""

    event_t: np.ndarray
    commands: np.ndarray  # (K, 8)
    t: np.ndarray  # (N,) fitting samples
    measured: np.ndarray  # (8, N)
    weight: np.ndarray  # (8, N) 1 where a sample counts (not at a stop)
    folds: np.ndarray  # (N,) 0 or 1
    limit: np.ndarray  # (8,) command limits
    servo_accel: np.ndarray
    lag: np.ndarray
    asked: np.ndarray  # (8,) the highest |command| sent
    jerk: np.ndarray | None = None  # (8,) the jerk-limited drives'; None: servos on the command
    material_accel: np.ndarray | None = None  # (8,) an acceleration limit at most this is material (_material)


def _values(params: dict, team: _Team, lanes: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Per lane: delay, speed, accel from grid shares."""
    return params["latency"], params["speed"] * team.limit[lanes], params["acceleration"] * team.servo_accel[lanes]


def _rss(team: _Team, drives: np.ndarray, params: dict) -> np.ndarray:
    """(L, 3) squared velocity error over all samples, fold 0 and fold 1, for lanes of (drive, parameter). Lanes
    with the same drive and values (the three fitting sets' candidates on a coarse grid) are computed once."""
    delay, speed, accel = _values(params, team, drives)
    lanes, first, inverse = np.unique(np.stack([drives, delay, speed, accel], axis=1), axis=0, return_index=True,
                                      return_inverse=True)
    if len(lanes) < len(drives):
        return _rss_of(team, drives[first], delay[first], speed[first], accel[first])[inverse.ravel()]
    return _rss_of(team, drives, delay, speed, accel)


def _rss_of(team: _Team, drives: np.ndarray, delay: np.ndarray, speed: np.ndarray, accel: np.ndarray) -> np.ndarray:
    v = shaped_velocity(team.event_t, team.commands[:, drives], team.t, delay, speed, accel, team.lag[drives],
                        None if team.jerk is None else team.jerk[drives])
    v -= team.measured[drives]
    v *= v
    v *= team.weight[drives]
    fold1 = v @ (team.folds == 1).astype(float)
    total = v.sum(axis=1)
    return np.stack([total, total - fold1, fold1], axis=1)


GRIDS = {"latency": DELAY_GRID, "speed": SPEED_GRID, "acceleration": ACCEL_GRID}


def _grid(component: str, team: _Team) -> np.ndarray:
    if component == "speed" and team.jerk is not None:
        return PROFILE_SPEED_GRID
    return GRIDS[component]
ABSENT = {"latency": 0.0, "speed": 1.0, "acceleration": 1.0}


def _fit_subset(team: _Team, subset: tuple[str, ...], held: dict | None = None) -> tuple[np.ndarray, dict]:
    """Coordinate descent of `subset` on grids for the 8 drives and 3 fitting sets (all, fold 0, fold 1);
    components outside it are absent, or held at `held`'s values ({component: (3,) per fitting set}).

    Returns rss (8, 3 fits, 3 evaluation sets) and the fitted values {component: (8, 3)} (grid shares)."""
    n = COMMAND_SIZE
    values = {c: np.full((n, 3), ABSENT[c]) for c in COMPONENTS}
    for c, v in (held or {}).items():
        values[c] = np.broadcast_to(np.asarray(v, dtype=float), (n, 3)).copy()
    for sweep in range(2 if len(subset) > 1 else 1):
        for c in subset:
            coarse = _grid(c, team)
            candidates = np.broadcast_to(coarse, (n, 3, len(coarse)))
            for _ in range(2):  # the coarse grid, then a fine one around each fit's best
                g = candidates.shape[2]
                drives = np.repeat(np.arange(n), 3 * g)
                params = {k: np.repeat(values[k], g, axis=1).ravel() for k in COMPONENTS}
                params[c] = candidates.ravel()
                rss = _rss(team, drives, params).reshape(n, 3, g, 3)
                own = rss[:, [0, 1, 2], :, [0, 1, 2]].transpose(1, 0, 2)  # each fit's own set: (8, 3, g)
                values[c] = np.take_along_axis(candidates, np.argmin(own, axis=2)[..., None], axis=2)[..., 0]
                fine_own, fine_candidates = own, candidates
                candidates = _fine(c, values[c], _grid(c, team))
            if team.jerk is not None:
                values[c] = _between_grid_points(team, values, c, fine_candidates, fine_own)
    drives = np.repeat(np.arange(n), 3)
    rss = _rss(team, drives, {k: values[k].ravel() for k in COMPONENTS}).reshape(n, 3, 3)
    return rss, values


def _between_grid_points(team: _Team, values: dict, component: str, candidates: np.ndarray, own: np.ndarray) -> np.ndarray:
    """(8, 3) each fit's value of `component`: the least of a parabola through its best fine-grid candidate and the two
    beside it (in log share for the limits), where that fits its own set better than the grid's best; else the grid's.

    On the jerk-limited drives (314 rad/s) the fine grids' steps (8 % on an acceleration limit, 1.5 ms on a latency)
    are far coarser than the data resolves: a rotation limit fitted 3.2 % low (693.3 rad/s^2, a grid point, for 716)
    left the calibrated rotations 25.6 deg off 0.25 s ahead against 0.17 deg of encoder noise (robot-bench-5, trial 6)."""
    g = candidates.shape[2]
    best_index = np.argmin(own, axis=2)
    middle = np.clip(best_index, 1, g - 2)
    x = candidates if component == "latency" else np.log(candidates)

    def at(array, index):
        return np.take_along_axis(array, index[..., None], axis=2)[..., 0]
    x0, x1, x2 = at(x, middle - 1), at(x, middle), at(x, middle + 1)
    y0, y1, y2 = at(own, middle - 1), at(own, middle), at(own, middle + 1)
    with np.errstate(divide="ignore", invalid="ignore"):
        slope01, slope12 = (y1 - y0) / (x1 - x0), (y2 - y1) / (x2 - x1)
        curvature = (slope12 - slope01) / (x2 - x0)
        vertex = np.clip((x0 + x1) / 2 - slope01 / (2 * curvature), x0, x2)
    # A parabola only where the best is inside the grid (not clipped at a bound: equal neighbours) and curves upward.
    ok = (best_index == middle) & (x0 < x1) & (x1 < x2) & (curvature > 0) & np.isfinite(vertex)
    grid_best = values[component]
    if not ok.any():
        return grid_best
    tried = np.where(ok, vertex if component == "latency" else np.exp(vertex), grid_best)
    n = len(grid_best)
    params = {k: values[k].ravel() for k in COMPONENTS}
    params[component] = tried.ravel()
    rss = _rss(team, np.repeat(np.arange(n), 3), params).reshape(n, 3, 3)
    tried_own = rss[:, [0, 1, 2], [0, 1, 2]]
    return np.where(ok & (tried_own < at(own, best_index)), tried, grid_best)


def _fine(component: str, best: np.ndarray, grid: np.ndarray) -> np.ndarray:
    """(8, 3, REFINE) candidates spanning one coarse grid step either side of each best value."""
    if component == "latency":
        step = DELAY_GRID[1] - DELAY_GRID[0]
        return np.maximum(best[..., None] + np.linspace(-step, step, REFINE), 0.0)
    ratio = grid[1] / grid[0]
    return np.minimum(best[..., None] * np.geomspace(1 / ratio, ratio, REFINE), 1.0)


def _noise2(measured: np.ndarray, weight: np.ndarray) -> np.ndarray:
    """Per drive velocity noise variance from second differences (robust: zero but at command changes)."""
    d2 = np.diff(measured, n=2, axis=1)
    ok = (weight[:, 2:] * weight[:, 1:-1] * weight[:, :-2]) > 0
    out = np.empty(len(measured))
    for i in range(len(measured)):
        x = d2[i][ok[i]]
        out[i] = (1.4826 * np.median(np.abs(x - np.median(x)))) ** 2 / 6.0 if x.size else np.inf
    return out


def _material(component: str, share: float, team: _Team, drive: int) -> bool:
    if component == "latency":
        return share >= MATERIAL_DELAY
    if component == "speed":
        return share * team.limit[drive] <= MATERIAL_SPEED * team.asked[drive]
    return share * team.servo_accel[drive] <= team.material_accel[drive]


def _variance_unit(noise2: float, rss: np.ndarray, weight: float, components: int) -> float:
    """A drive's variance unit for evidence: its noise variance, or its fit's residual scatter (rss (3 fits, 3 sets)
    over `weight` samples less the fitted components) when that is larger."""
    return max(noise2, float(rss[0, 0]) / max(1.0, weight - components))


def _held_out_drops(before: np.ndarray, after: np.ndarray, unit: float) -> list[float]:
    """Held-out squared-error drops from fit `before` to fit `after` (each (3 fits, 3 sets)), in `unit`: fold 1
    under fold 0's fit, and fold 0 under fold 1's."""
    return [float(before[1, 2] - after[1, 2]) / unit, float(before[2, 1] - after[2, 1]) / unit]


def _earns(drops: list[float]) -> bool:
    """MIN_EVIDENCE held out in all, and no fold worse by more than MIN_FOLD_SHARE of it (or 10)."""
    return sum(drops) >= MIN_EVIDENCE and min(drops) >= -max(10.0, MIN_FOLD_SHARE * sum(drops))


def _in_order(components: tuple[str, ...]) -> tuple[str, ...]:
    return tuple(c for c in COMPONENTS if c in components)


def _nuisance_latency(fits: dict, noise2: float, weight: float, team: _Team, drive: int) -> tuple[tuple[str, ...], dict]:
    """(("latency",), its evidence entry) where a dead time too small to name (under MATERIAL_DELAY: commands
    stamped when sent and arriving a few ms later, say) still earns its held-out evidence: fitted as a nuisance, it
    keeps a rate limit from being named in its place. ((), {}) otherwise."""
    rss, values = fits[("latency",)]
    unit = _variance_unit(noise2, rss[drive], weight, 1)
    drops = _held_out_drops(fits[()][0][drive], rss[drive], unit)
    material = _material("latency", float(values["latency"][drive, 0]), team, drive)
    if not _earns(drops) or material:
        return (), {}
    return ("latency",), {**_evidence(drops, unit, noise2, False), "fitted_as_nuisance_s": round(float(values["latency"][drive, 0]), 4)}


def _evidence(drops: list[float], unit: float, noise2: float, material: bool) -> dict:
    """A candidate component's evidence entry on one drive (report.json's per-drive evidence)."""
    return {"held_out_error_drop_noise_variances": round(float(sum(drops)), 1), "per_fold": [round(float(x), 1) for x in drops],
            "residual_scatter_over_noise": round(float(np.sqrt(unit / noise2)), 2), "material": bool(material)}


def _select_team(team: _Team, progress) -> list[dict]:
    """Per drive of the team: the named components, their values (all data, fold 0, fold 1) and evidence."""
    fits = {}
    for size in range(len(COMPONENTS) + 1):
        for subset in itertools.combinations(COMPONENTS, size):
            fits[subset] = _fit_subset(team, subset)
    noise2 = _noise2(team.measured, team.weight)
    out = []
    for d in range(COMMAND_SIZE):
        chosen: tuple[str, ...] = ()
        info: dict[str, dict] = {}
        nuisance, entry = _nuisance_latency(fits, noise2[d], float(team.weight[d].sum()), team, d)
        if nuisance:
            info["latency"] = entry  # in the model while the limits are judged, never named
        while True:
            current = fits[_in_order(chosen + nuisance)][0][d]
            best = None
            for c in COMPONENTS:
                if c in chosen or c in nuisance:
                    continue
                subset = _in_order(chosen + nuisance + (c,))
                rss, values = fits[subset]
                scale2 = _variance_unit(noise2[d], rss[d], float(team.weight[d].sum()), len(subset))
                drops = _held_out_drops(current, rss[d], scale2)
                entry = _evidence(drops, scale2, noise2[d], _material(c, float(values[c][d, 0]), team, d))
                ok = _earns(drops) and entry["material"]
                if ok and (best is None or sum(drops) > best[1]):
                    best = (c, sum(drops), subset, entry)
                info[c] = entry  # the latest look at each candidate not (yet) named
            if best is None:
                break
            c, _, fitted, entry = best
            chosen = tuple(x for x in fitted if x not in nuisance)
            info[c] = {**entry, "named": True}
        rss, values = fits[_in_order(chosen + nuisance)]
        rss = rss[d]
        scale2 = _variance_unit(noise2[d], rss, float(team.weight[d].sum()), len(chosen))
        out.append({"chosen": chosen, "values": {c: values[c][d] for c in chosen}, "evidence": info, "rss": rss, "scale2": scale2})
    return out


def _hold_common_latency(teams: list[_Team], per_drive: list[dict]) -> None:
    """A drive's latency, where that drive also names a speed or acceleration limit, other than the common one
    only on its own evidence.

    On one drive a dead time and a rate limit trade off (both delay the response to a step): a limit fitted
    high leaves the rest of the delay to a dead time of its own, one fitted low takes in the dead time (the
    drive names none), with held-out errors near the noise either way. The common latency (the median of the
    drives that name one, where most do; else none) acts on every drive, so such a drive is refitted with its
    latency held at the common one and its other components refitted. It keeps its own latency (or none) only
    where that beats the refit by MIN_EVIDENCE held out, with no fold losing; otherwise it takes the refit."""
    named = [d["values"]["latency"] for d in per_drive if "latency" in d["chosen"]]
    common = np.median(named, axis=0) if len(named) > len(per_drive) / 2 else np.zeros(3)  # per fitting set
    for i, team in enumerate(teams):
        suspects = {}
        for d in range(COMMAND_SIZE):
            drive = per_drive[i * COMMAND_SIZE + d]
            others = tuple(c for c in drive["chosen"] if c != "latency")
            own = float(drive["values"]["latency"][0]) if "latency" in drive["chosen"] else 0.0
            if others and _differs("latency", own, float(common[0])):
                suspects.setdefault(others, []).append(d)
        for others, drives in suspects.items():
            rss, values = _fit_subset(team, others, {"latency": common})
            for d in drives:
                drive = per_drive[i * COMMAND_SIZE + d]
                drops = _held_out_drops(rss[d], drive["rss"], drive["scale2"])
                earned = _earns(drops)
                drive["evidence"]["latency"] = {**drive["evidence"]["latency"],
                                                "own_over_common_noise_variances": round(float(sum(drops)), 1),
                                                "own_over_common_per_fold": [round(float(x), 1) for x in drops]}
                if earned:
                    continue
                drive["evidence"]["latency"]["held_at_common"] = True
                drive["chosen"] = tuple(c for c in COMPONENTS if c in others or (c == "latency" and common[0] > 0))
                drive["values"] = {c: values[c][d] for c in drive["chosen"]}  # a latency named is the common one
                drive["rss"] = rss[d]


# --- from drives to effects ------------------------------------------------------------------------
def _physical(component: str, share: float, drive: int, model: DriveModel) -> float:
    if component == "latency":
        return float(share)
    if component == "speed":
        return float(share * model.command_limits[drive])
    return float(share * model.servo_accel[drive])


def _differs(component: str, value: float, reference: float) -> bool:
    if component == "latency":
        return abs(value - reference) > max(DIFFERENT_DELAY[0], DIFFERENT_DELAY[1] * reference)
    return max(value, reference) / min(value, reference) > DIFFERENT_RATIO


def _round(value: float) -> float:
    return float(f"{value:.4g}")


def combine(per_drive: list[dict], model: DriveModel, column: int = 0) -> tuple[list[dict], dict]:
    """Effects in the contract's vocabulary from the 16 drives' choices (values of fit `column`: 0 all
    data, 1 fold 0, 2 fold 1), and for each effect the drives it rests on."""
    effects, basis = [], {}
    axes = {"slide": [j for j, n in enumerate(JOINT_NAMES) if n.endswith("_slide")],
            "rotate": [j for j, n in enumerate(JOINT_NAMES) if n.endswith("_rotate")]}
    for component in COMPONENTS:
        name = EFFECT_OF[component]
        global_params, single = {}, {}
        groups = {"all": list(range(len(JOINT_NAMES)))} if component == "latency" else axes
        for group, drives in groups.items():
            named = {j: _physical(component, per_drive[j]["values"][component][column], j, model)
                     for j in drives if component in per_drive[j]["chosen"]}
            if not named:
                continue
            if len(named) > len(drives) / 2:
                reference = float(np.median(list(named.values())))
                global_params["delay" if component == "latency" else group] = _round(reference)
                odd = {j: v for j, v in named.items() if _differs(component, v, reference)}
            else:
                odd = named
            for j, value in odd.items():
                team, rod, axis = JOINT_NAMES[j].split("_")
                single.setdefault((team, rod), {})[axis] = _round(value)
        if global_params:
            effects.append({"name": name, "params": global_params})
            basis[(name, None)] = [JOINT_NAMES[j] for j in range(len(JOINT_NAMES)) if component in per_drive[j]["chosen"]]
        for (team, rod), by_axis in single.items():
            if component == "latency":
                if len(by_axis) == 2 and not _differs(component, by_axis["slide"], by_axis["rotate"]):
                    effects.append({"name": name, "params": {"delay": _round((by_axis["slide"] + by_axis["rotate"]) / 2),
                                                             "team": team, "rod": rod}})
                else:
                    effects += [{"name": name, "params": {"delay": v, "team": team, "rod": rod, "axis": axis}}
                                for axis, v in by_axis.items()]
            else:
                effects.append({"name": name, "params": {**by_axis, "team": team, "rod": rod}})
            basis[(name, (team, rod))] = [f"{team}_{rod}_{axis}" for axis in by_axis]
    return effects, basis


def limits_of(effects: list[dict]) -> DriveLimits:
    limits = drive_limits_from_effects(effects)
    n = len(JOINT_NAMES)
    return limits if limits is not None else DriveLimits(np.zeros(n), np.full(n, np.inf), np.full(n, np.inf))


# --- identification and its gain --------------------------------------------------------------------
def fit_samples(t: np.ndarray) -> np.ndarray:
    """Indices of the joint states the fit uses: the sample nearest each point of a FIT_RATE grid over the game
    (every sample where the encoders are slower; a gap of lost samples is not filled)."""
    grid = np.arange(t[0], t[-1] + 0.5 / FIT_RATE, 1.0 / FIT_RATE)
    return np.unique(drive_prediction.nearest_samples(t, grid))


def _teams(data: DriveData, model: DriveModel) -> list[_Team]:
    slide = np.array([n.endswith("_slide") for n in JOINT_NAMES])
    at_stop = slide[None, :] & (np.abs(data.position) > model.travel[None, :] - STOP_MARGIN)
    folds = (np.floor((data.t - data.t[0]) / STRETCH).astype(int) % 2)
    teams = []
    for i, team in enumerate(TEAMS):
        cols = slice(i * COMMAND_SIZE, (i + 1) * COMMAND_SIZE)
        commands = np.clip(data.commands[team], -model.command_limits[cols], model.command_limits[cols])
        every = fit_samples(data.t)
        teams.append(_Team(
            event_t=data.command_t[team], commands=commands, t=data.t[every], measured=data.velocity[every, cols].T,
            weight=(~at_stop[every, cols]).T.astype(float), folds=folds[every], limit=model.command_limits[cols],
            servo_accel=model.servo_accel[cols], lag=model.lag[cols], asked=np.abs(commands).max(axis=0),
            jerk=None if model.jerk is None else model.jerk[cols]))
        team = teams[-1]
        team.material_accel = MATERIAL_ACCEL * team.servo_accel
        if team.jerk is not None:
            _, reached = shaped_velocity(team.event_t, team.commands, team.t, np.zeros(COMMAND_SIZE), team.limit, team.servo_accel,
                                         np.zeros(COMMAND_SIZE), team.jerk, acceleration=True)
            team.material_accel = MATERIAL_PROFILE_ACCEL * np.abs(reached).max(axis=1)
    return teams



def model_velocity(data: DriveData, model: DriveModel, limits: DriveLimits, times: np.ndarray,
                   acceleration: bool = False):
    """(len(times), 16): each drive's velocity under `limits`, from the commands alone; with `acceleration`, and
    the jerk-limited drives' setpoint acceleration (zeros on servos)."""
    out = np.zeros((len(times), len(JOINT_NAMES)))
    accel_out = np.zeros((len(times), len(JOINT_NAMES)))
    for i, team in enumerate(TEAMS):
        cols = np.arange(i * COMMAND_SIZE, (i + 1) * COMMAND_SIZE)
        commands = np.clip(data.commands[team], -model.command_limits[cols], model.command_limits[cols])
        speed = np.minimum(limits.speed[cols], model.command_limits[cols])
        accel = np.minimum(limits.acceleration[cols], model.servo_accel[cols])
        jerk = None if model.jerk is None else model.jerk[cols]
        shaped = shaped_velocity(data.command_t[team], commands, times, limits.delay[cols], speed, accel, model.lag[cols], jerk,
                                 acceleration=jerk is not None)
        if jerk is not None:
            out[:, cols], accel_out[:, cols] = shaped[0].T, shaped[1].T
        else:
            out[:, cols] = shaped.T
    return (out, accel_out) if acceleration else out


def prediction_errors(data: DriveData, model: DriveModel, fold_limits: list[DriveLimits]) -> tuple[np.ndarray, np.ndarray]:
    """(starts, horizons, 16) absolute position errors 0.1 and 0.25 s ahead, and each start's stretch (its fold
    is the stretch's parity).

    A start on fold k is predicted with fold_limits[1 - k] (fitted on the other fold). The velocity at the
    start is the model's own, from the commands before it (the encoders' velocity is too noisy to start
    from); the position is the measured one. Each horizon ends on the encoder sample nearest it, predicted at its time:
    a rod turning at 1000 rad/s^2 is 8 mrad (a dt^2 / 8) off the line between samples 8 ms apart, 2.7x the noise."""
    span = data.t[-1] - max(HORIZONS)
    t0 = np.arange(data.t[0] + 0.5, span, START_SPACING)
    t0 = data.t[np.searchsorted(data.t, t0)]
    stretch = np.floor((t0 - data.t[0]) / STRETCH).astype(int)
    folds = stretch % 2
    errors = np.full((len(t0), len(HORIZONS), len(JOINT_NAMES)), np.nan)
    for k in (0, 1):
        rows = np.flatnonzero(folds == k)
        if rows.size == 0:
            continue
        limits = fold_limits[1 - k]
        # A jerk-limited drive's position is its setpoint's integral: the prediction starts from the setpoint at t0.
        ahead = model.timestep / 2 if model.profiles is not None else 0.0
        v0, a0 = model_velocity(data, model, limits, t0[rows] + ahead, acceleration=True)
        p0 = data.position[np.searchsorted(data.t, t0[rows])]
        ends = drive_prediction.nearest_samples(data.t, t0[rows][:, None] + np.array(HORIZONS)[None, :])
        for i, team in enumerate(TEAMS):
            cols = np.arange(i * COMMAND_SIZE, (i + 1) * COMMAND_SIZE)
            team_limits = limits.team(team)
            if model.profiles is None:
                predicted = _servo_positions(data, model, limits, team, cols, t0[rows], p0[:, cols], v0[:, cols], data.t[ends])
            else:
                speed = np.minimum(team_limits.speed, model.command_limits[cols])
                predicted = drive_prediction.profile_positions(
                    t0[rows], p0[:, cols], v0[:, cols], a0[:, cols], data.command_t[team][:, None] + team_limits.delay[None, :],
                    np.clip(data.commands[team], -speed, speed), np.minimum(team_limits.acceleration, model.profiles.acceleration[cols]),
                    model.profiles.jerk[cols], data.t[ends], model.travel[cols])
            for h in range(len(HORIZONS)):
                error = np.abs(predicted[:, h] - data.position[ends[:, h]][:, cols])
                # A slide that meets its travel stop is left out: the stops are soft (a slide driven into one goes
                # several cm past its travel in MuJoCo), and no part of the drive model.
                first = np.searchsorted(data.t, t0[rows])
                reach = np.array([np.abs(data.position[i:j + 1, cols]).max(axis=0) for i, j in zip(first, ends[:, h])])
                near = reach > model.travel[cols] - STOP_MARGIN  # at a stop somewhere on the way
                errors[rows[:, None], h, cols[None, :]] = np.where(near, np.nan, error)
    return errors, stretch


def _servo_positions(data: DriveData, model: DriveModel, limits: DriveLimits, team: str, cols: np.ndarray, t0: np.ndarray,
                     p0: np.ndarray, v0: np.ndarray, ends: np.ndarray) -> np.ndarray:
    """The velocity servos' rods at `ends`: as the fast physics steps them, or by the servo law (model.continuous,
    drive_prediction.continuous_servo_positions), whose velocity at t0 is then its own response to the commands over
    the SERVO_SETTLE time constants before (from the model's lagged velocity there): a slide's servo (I / kv 3-5 ms)
    filters commands that change every 2 ms; it does not delay them."""
    servo = Servo(model.servo.inertia[cols], model.servo.gain[cols], model.servo.force_limit[cols])
    if not model.continuous:
        return drive_prediction.stepped_servo_positions(t0, p0, v0, data.command_t[team], data.commands[team], limits.team(team),
                                                        servo, model.command_limits[cols], model.travel[cols], model.timestep, ends)
    speed = np.minimum(limits.speed[cols], model.command_limits[cols])
    commands = np.clip(data.commands[team], -speed, speed)
    due, rate = data.command_t[team][:, None] + limits.delay[cols][None, :], limits.acceleration[cols]
    finite_rate = np.minimum(rate, 1e15)  # shaped_velocity's ramp: 0 s x inf would be NaN

    def target(times):  # the servos' (rate-limited) target
        return shaped_velocity(data.command_t[team], commands, times, limits.delay[cols], speed, finite_rate, 0.0 * speed).T
    warm = SERVO_SETTLE * float(np.max(servo.inertia / servo.gain))
    start = model_velocity(data, model, limits, t0 - warm)[:, cols]
    _, v0 = drive_prediction.continuous_servo_positions(t0 - warm, np.zeros_like(p0), start, target(t0 - warm), due, commands,
                                                        rate, servo, t0[:, None], np.full(len(cols), np.inf))
    return drive_prediction.continuous_servo_positions(t0, p0, v0, target(t0), due, commands, rate, servo, ends,
                                                       model.travel[cols])[0]


def gain_summary(errors: np.ndarray, seed: int = 0, n_boot: int = 1000) -> dict:
    """Median errors (slides mm, rotations deg) per horizon with bootstrap 95 % intervals over starts."""
    rng = np.random.default_rng(seed)
    slide = np.array([n.endswith("_slide") for n in JOINT_NAMES])
    out = {}
    for axis, mask, scale, unit in (("slide", slide, 1000.0, "mm"), ("rotate", ~slide, 180.0 / np.pi, "deg")):
        for h, horizon in enumerate(HORIZONS):
            per_start = errors[:, h][:, mask] * scale  # (starts, drives), NaN: a slide at a stop
            per_start = per_start[np.isfinite(per_start).any(axis=1)]
            key = f"{axis}_median_error_{unit}_{horizon:g}s".replace(".", "_")
            if len(per_start) == 0:
                out[key] = None
                continue
            # Resample starts (each start carries its drives' errors): the drives of one start are not independent.
            picks = rng.integers(0, len(per_start), size=(n_boot, len(per_start)))
            boot = np.array([np.nanmedian(per_start[p]) for p in picks])
            out[key] = round(float(np.nanmedian(per_start)), 3)
            out[key.replace("median_error", "ci95")] = [round(float(np.percentile(boot, 2.5)), 3),
                                                         round(float(np.percentile(boot, 97.5)), 3)]
    out["starts"] = int(len(errors))
    return out


def per_drive_errors(nominal: np.ndarray, calibrated: np.ndarray, horizon: float = 0.25) -> dict:
    """Each drive's median error `horizon` ahead, nominal and calibrated (slides mm, rotations deg). A per-drive
    effect shows here: one slow drive hardly moves the medians over all 16."""
    h = HORIZONS.index(horizon)
    out = {}
    for j, name in enumerate(JOINT_NAMES):
        scale, unit = (1000.0, "mm") if name.endswith("_slide") else (180.0 / np.pi, "deg")
        pair = [errors[:, h, j][np.isfinite(errors[:, h, j])] * scale for errors in (nominal, calibrated)]
        if all(len(p) for p in pair):
            out[name] = {"baseline": round(float(np.median(pair[0])), 3), "calibrated": round(float(np.median(pair[1])), 3),
                         "unit": unit}
    return out


def identify(data: DriveData, model: DriveModel, progress: Callable[[str], None] = lambda message: None,
             seed: int = 0) -> RodResult:
    """The drive effects the game supports, with evidence, and the report's `rods` block."""
    progress("fitting the rod drives (latency, speed and acceleration limits) per drive, on two folds")
    drive_shaping.new_game()
    teams = _teams(data, model)
    per_drive = []
    for team in teams:
        per_drive += _select_team(team, progress)
    _hold_common_latency(teams, per_drive)
    effects, basis = combine(per_drive, model, 0)
    fold_effects = [combine(per_drive, model, column)[0] for column in (1, 2)]  # fitted on fold 0, on fold 1
    for effect in effects:
        where = (effect["params"].get("team"), effect["params"].get("rod"))
        drives = basis.get((effect["name"], None if where == (None, None) else where), [])
        component = next(c for c, n in EFFECT_OF.items() if n == effect["name"])
        effect["evidence"] = {
            "drives_named": len(drives),
            "held_out_error_drop_noise_variances": round(float(sum(
                per_drive[JOINT_NAMES.index(j)]["evidence"][component]["held_out_error_drop_noise_variances"] for j in drives)), 1),
            "per_drive": {j: per_drive[JOINT_NAMES.index(j)]["evidence"][component] for j in drives},
        }
    progress("judging each drive effect's held-out gain, alone and in the final set")
    effects, fold_effects, refused = drive_gain.judge_gains(
        lambda fold_sets: prediction_errors(data, model, [limits_of(e) for e in fold_sets]), effects, fold_effects, seed)
    progress("predicting joint positions 0.1 and 0.25 s ahead on held-out stretches")
    nominal = limits_of([])
    nominal_errors, _ = prediction_errors(data, model, [nominal, nominal])
    calibrated_errors, _ = prediction_errors(data, model, [limits_of(e) for e in fold_effects]) if effects else (nominal_errors, None)
    rejected = {}
    for j, drive in enumerate(per_drive):
        for c, entry in drive["evidence"].items():
            if c not in drive["chosen"] and entry["held_out_error_drop_noise_variances"] >= MIN_EVIDENCE:
                rejected.setdefault(EFFECT_OF[c], {})[JOINT_NAMES[j]] = entry
    block = {
        "data": {"joint_states": int(len(data.t)), "duration_s": round(float(data.t[-1] - data.t[0]), 2),
                 "commands": {team: int(len(data.command_t[team])) for team in TEAMS}},
        "baseline": gain_summary(nominal_errors, seed),
        "calibrated": gain_summary(calibrated_errors, seed),
        "per_drive": _per_drive_named(per_drive, model, limits_of(effects)),
        "refused_for_no_gain": refused,
        "per_drive_error_0_25s": per_drive_errors(nominal_errors, calibrated_errors),
        "rejected": rejected,
        "method": {
            "model": "dead time, speed clip, rate limit on the received commands; the nominal servo's own acceleration "
                     "(force / inertia) and lag (inertia / gain) after them (foos_sim.drive_limits)",
            "fit": "per drive, every subset of {latency, speed, acceleration} on grids (coordinate descent), velocity residuals "
                   "of /joint_states against the commands; slide samples at a travel stop left out",
            "selection": f"forward per drive: held-out squared-error drop (2 alternating folds of {STRETCH:g} s stretches) over "
                         f"{MIN_EVIDENCE:g} noise variances and material; one effect for all drives when most drives of the axis "
                         "name it (median value), a per-drive effect where a drive differs materially or few drives name it; "
                         "a drive with a limit of its own keeps a latency other than the common one only on its held-out "
                         f"evidence ({MIN_EVIDENCE:g} noise variances) over a refit with the common latency",
            "gain": "joint position error 0.1 s and 0.25 s ahead from starts every 0.2 s, each predicted with the parameters "
                    "fitted on the other fold; medians over starts and drives, slides in mm, rotations in degrees, bootstrap "
                    "95 % intervals over starts; slides that come within 1 cm of a travel stop before the horizon left out "
                    "(soft stops, not modelled)",
        },
    }
    return RodResult(effects, block, [limits_of(e) for e in fold_effects], refused)


def _per_drive_named(per_drive: list[dict], model: DriveModel, final: DriveLimits) -> dict:
    """Each drive's fitted components that a kept effect carries (a refused effect's drives name nothing)."""
    carried = {"latency": final.delay > 0, "speed": np.isfinite(final.speed), "acceleration": np.isfinite(final.acceleration)}
    out = {}
    for j, d in enumerate(per_drive):
        own = {c: _round(_physical(c, d["values"][c][0], j, model)) for c in d["chosen"] if carried[c][j]}
        if own:
            out[JOINT_NAMES[j]] = own
    return out
