"""calibrate: measured detections -> what is wrong, why, the fitted model file, and the gain."""
from __future__ import annotations

import json
import math
import time
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Callable

import numpy as np
import yaml

from foos_core.table_geometry import TableGeometry
from foos_core.table_params import load_params

from . import (
    effect_gain,
    figures,
    hidden_touches,
    rod_report,
    surface_correction,
    surrogate,
    table_gain,
    wall_segments,
)
from . import rods as rod_drives
from .bounces import fit_restitution, fold_restitution
from .evaluate import HORIZONS, choose_starts, errors_of, estimate_states, predict, summary
from .figure_contacts import JointTrack, for_game
from .fitting import SegmentBatch, fit
from .game_ball import camera_and_figures
from .game_data import Encoders, drive_model
from .mjsim import base_effect_names, effects_list, params_with, restitution_of, theta_of
from .select import free_indices, select_effects
from .tracks import DataError, analyse, validate
from .unexplained import FAR_ABOVE, FIGURE_FILE, find_unexplained, prediction_floor, unexplained_predictions

PARAMS_FILE_NAME = "calibrated_table.yaml"
MIN_SEGMENTS = 6
# A recording without encoders in which the ball left a figure this often is a game filmed by a camera alone, not
# free rolls with the rods lifted (where the rod lines find no figure contact at all).
CAMERA_GAME_FIGURE_CONTACTS = 3


@dataclass
class Options:
    max_starts: int = 40
    seed: int = 0
    figures: bool = True
    base: str | None = None  # parameter file of the table to start from (None: the regulation table)
    # Benchmarks only: (surrogate theta of the true table, predictor(states (n,4), horizons) -> (n, H, 2)),
    # to report the error of the true generating model from the same starts (the floor).
    floor: tuple | None = None


def describe(effect: dict, nominal_rolling: float, nominal_restitution: float) -> str:
    """One plain sentence: what is different about this table and which MuJoCo mechanism models it."""
    name, p = effect["name"], effect["params"]
    if name == "table_tilt":
        slope = math.hypot(p["slope_x"], p["slope_y"])
        angle = math.degrees(math.atan2(p["slope_y"], p["slope_x"]))
        return (f"The table is tilted: the surface descends {slope * 100:.2f} % (slope {slope:.4f}) toward the direction "
                f"{angle:.0f} deg from +x (slope_x {p['slope_x']:+.4f}, slope_y {p['slope_y']:+.4f}), so a rolling ball drifts "
                f"at {5 / 7 * 9.81 * slope:.3f} m/s^2. Modelled by tilting MuJoCo's gravity vector.")
    if name == "rolling_resistance":
        return (f"Rolling resistance is {p['deceleration']:.3f} m/s^2, {p['deceleration'] / nominal_rolling:.2f} x the nominal "
                f"{nominal_rolling:.3f} m/s^2 (cloth or ball). Modelled by the ball-field rolling friction.")
    if name == "viscous_damping":
        return (f"The ball loses speed in proportion to its speed: viscous rate {p['rate']:.3f} /s. Modelled by MuJoCo's "
                f"fluid viscosity (Stokes drag on the ball).")
    if name == "air_drag":
        return (f"The ball loses speed in proportion to its speed squared: drag coefficient {p['coefficient']:.3f} /m. "
                f"Modelled by MuJoCo's fluid density (blunt drag of the ellipsoid fluid model).")
    if name == "surface_dent":
        kind = "dent" if p["depth"] > 0 else "bump"
        return (f"The surface has a {abs(p['depth']) * 1000:.1f} mm deep {kind} of radius {p['radius'] * 100:.1f} cm at "
                f"x = {p['x']:+.3f} m, y = {p['y']:+.3f} m. Modelled by a height field in place of the flat field.")
    if name == "wall_restitution":
        return (f"The walls return {p['coefficient']:.2f} of the normal speed instead of the nominal {nominal_restitution:.2f}. "
                f"Modelled by the damping of the ball-wall contacts.")
    return name


def calibrate(t: np.ndarray | None, position: np.ndarray | None, frame_id: str, out_dir: Path, options: Options = Options(),
              progress: Callable[[str], None] = lambda message: None, bag: str = "",
              drives: "rod_drives.DriveData | None" = None, encoders: "Encoders | None" = None) -> dict:
    """The ball (detections t, position) and, for a game, the rod drives (joint states and commands).

    `encoders` (a game's /joint_states) pose the figures, whose contacts cut the ball's tracks; without
    them, sudden velocity changes near a rod line do (figure_contacts).

    The drives are calibrated first: a game bag whose ball side cannot be used (too little rolling data,
    no detections) still gets its rods calibrated and reported, with the reason the ball was skipped."""
    started, cpu_started = time.monotonic(), time.process_time()
    rods = None
    if drives is not None:
        rods = rod_drives.identify(drives, drive_model(load_params(options.base)), progress, options.seed)
    if t is None:
        if rods is None:
            raise DataError("no ball detections and no drive data to calibrate")
        return _rods_only(rods, "the bag has no ball detections", out_dir, options, bag, started, cpu_started)
    try:
        return _calibrate_ball(t, position, frame_id, out_dir, options, progress, bag, rods, encoders, started, cpu_started)
    except DataError as error:
        if rods is None:
            raise
        return _rods_only(rods, str(error).splitlines()[0], out_dir, options, bag, started, cpu_started)


def _rods_only(rods, reason: str, out_dir: Path, options: Options, bag: str, started: float, cpu_started: float) -> dict:
    """The report of a game whose ball side was skipped: the drive effects, their gain, and why."""
    out_dir.mkdir(parents=True, exist_ok=True)
    params_file = out_dir / PARAMS_FILE_NAME
    base_ref = str(Path(options.base).resolve()) if options.base else "regulation_table"
    base_effects = [e for e in load_params(options.base).get("effects", []) or []
                    if e.get("name") not in rod_drives.EFFECT_OF.values()]
    params_file.write_text("# Calibrated table written by `ros2 run foos_calibration calibrate` (rod drives only; the ball was "
                           f"skipped: {reason}).\n" + yaml.safe_dump(
                               {"base": base_ref, "effects": base_effects + _plain_effects(rods.effects)}, sort_keys=False))
    load_params(params_file)
    effects = [{**e, "description": rod_report.describe(e)} for e in rods.effects]
    report = {"effects": effects, "baseline": {"median_error_mm_1s": None}, "calibrated": {"median_error_mm_1s": None},
              "params_file": str(params_file.resolve()), "ball_skipped": reason, "rods": rods.block,
              "rejected": _rejected(None, None, rods),
              "unexplained": [],  # the ball was not judged: `ball_skipped` says why, and the summary says so
              "data": {"bag": bag}, "runtime_s": round(time.monotonic() - started, 1),
              "cpu_s": round(time.process_time() - cpu_started, 1)}
    (out_dir / "report.json").write_text(json.dumps(report, indent=2, default=_plain))
    (out_dir / "report.md").write_text(f"# Calibration report\n\nThe ball was not calibrated: {reason}.\n"
                                       + rod_report.markdown(rods.block, rods.effects))
    return report


def _plain_effects(effects: list[dict]) -> list[dict]:
    """Effects as a parameter file holds them: name and params only."""
    return [{"name": e["name"], "params": dict(e["params"])} for e in effects]


def _calibrate_ball(t, position, frame_id, out_dir, options, progress, bag, rods, encoders, started, cpu_started) -> dict:
    params = load_params(options.base)
    # The drives are calibrated apart: the ball side starts from the base table without its drive effects, which
    # the calibrated file keeps unless the game's drives replaced them.
    base_drive_effects = [e for e in params.get("effects", []) or [] if e.get("name") in rod_drives.EFFECT_OF.values()]
    params = {**params, "effects": [e for e in params.get("effects", []) or [] if e not in base_drive_effects]}
    theta_base = theta_of(params)
    nominal_rolling = float(theta_base[2])
    nominal_e = restitution_of(params)
    kept = base_effect_names(params)  # effects the base table already has
    geometry = TableGeometry.from_params(params)
    t, xy = validate(t, position, frame_id)
    progress("finding tracks, wall and figure contacts, and rolling segments")
    joints = JointTrack(encoders.t, encoders.position) if encoders is not None else None
    game = camera_and_figures(t, xy, geometry, params, joints, options.seed, progress) if joints is not None else None
    if game is not None:
        t = game.t  # the detections at capture time (a named camera latency taken off)
    measured = analyse(t, xy, geometry, figures=for_game(params, joints, game.figure_model if game is not None else None))
    # A game filmed by a camera alone (the ball met figures, no encoders posed them): cut the rolling segments where
    # a touch the rod lines missed hides, and judge each table effect's gain on the long free stretches only.
    camera_game = joints is None and sum(f.after_figure for f in measured.flights) >= CAMERA_GAME_FIGURE_CONTACTS
    hidden_cuts = 0
    if camera_game:
        progress("cutting the rolling segments at touches the camera alone did not see")
        segments, hidden_cuts = hidden_touches.split_hidden_touches(measured.segments, measured.noise)
        measured = replace(measured, segments=segments)
    if len(measured.segments) < MIN_SEGMENTS:
        raise DataError(f"too little rolling data: {len(measured.segments)} rolling segments of at least 0.25 s "
                        f"(need {MIN_SEGMENTS}); record more rolls")
    selection = select_effects(measured.segments, measured.noise, theta_base, geometry, progress)
    progress("measuring each rolling effect's held-out gain")
    # with a camera alone the inferred figure contacts may hide a touch in a short segment (table_gain)
    _judge_gains(measured, selection, theta_base, options.seed, progress,
                 min_duration=table_gain.CAMERA_ONLY_MIN_STRETCH if camera_game else 0.0)
    modelled = list(dict.fromkeys(kept + selection.effects))  # base effects, refitted or kept, and new ones
    rolling_effects = effects_list(modelled, selection.fit.theta)
    progress("fitting wall restitution on MuJoCo replays of the bounces")
    restitution = fit_restitution(measured, selection.fit, params_with(rolling_effects, params), nominal_e, measured.noise)
    effects = effects_list(selection.effects, selection.fit.theta, restitution.coefficient)  # what changed
    base_e = None if nominal_e == float(params["walls"]["restitution"]) else nominal_e
    table_effects = effects_list(modelled, selection.fit.theta,
                                 restitution.coefficient if restitution.coefficient is not None else base_e)

    out_dir.mkdir(parents=True, exist_ok=True)
    params_file = out_dir / PARAMS_FILE_NAME
    header = ("# Calibrated table written by `ros2 run foos_calibration calibrate`: the regulation table plus the effects the\n"
              f"# measured data supports ({bag or 'detections'}). Load with foos_sim.load_model(this file) or\n"
              "# `ros2 run foos_sim sim_node --ros-args -p params_file:=<this file>`.\n")
    base_ref = str(Path(options.base).resolve()) if options.base else "regulation_table"
    rod_effects = _plain_effects(rods.effects) if rods is not None else base_drive_effects
    # The figures' restitution belongs to the table; the camera's latency does not (it is the camera's).
    figure_effects = _plain_effects(game.figures.effects) if game is not None else []
    params_file.write_text(header + yaml.safe_dump({"base": base_ref, "effects": table_effects + figure_effects + rod_effects},
                                                   sort_keys=False))
    load_params(params_file)  # the file must be loadable; raises if not

    progress("measuring the gain on held-out starts (MuJoCo rollouts)")
    starts = choose_starts(measured, options.max_starts, options.seed)
    theta_nominal = theta_base
    models = {"nominal": ([params], [theta_nominal] * len(starts), [0] * len(starts))}
    if effects:
        trees, thetas, index = [], [], []
        for k in (0, 1):
            e_k = fold_restitution(restitution, k, nominal_e) if restitution.coefficient is not None else base_e
            trees.append(params_with(effects_list(modelled, selection.fold_theta[k], e_k), params))
        for s in starts:
            other = 1 - s.fold  # the fold this start's segment was not fitted on
            thetas.append(selection.fold_theta[other])
            index.append(other)
        models["calibrated"] = (trees, thetas, index)
    predictions = predict(measured, starts, models) if starts else None
    baseline = summary(predictions.errors["nominal"], options.seed) if predictions else {"median_error_mm_1s": None}
    calibrated = summary(predictions.errors["calibrated"], options.seed) if predictions and effects else dict(baseline)
    if options.floor is not None and starts:
        floor_started, floor_cpu_started = time.monotonic(), time.process_time()
        floor_theta, predictor = options.floor
        states = estimate_states(starts, [floor_theta] * len(starts))
        floor = summary(errors_of(measured, starts, predictor(states, HORIZONS)), options.seed)
        # The floor is the benchmark's time, not calibration's.
        started += time.monotonic() - floor_started
        cpu_started += time.process_time() - floor_cpu_started
    else:
        floor = None
    for block, n in ((baseline, len(starts)), (calibrated, len(starts))):
        block["starts"] = n

    # What the final model (the calibrated one, else the nominal) still leaves: never claim what the residuals deny.
    progress("looking for what the model still misses")
    final_label = "calibrated" if effects else "nominal"
    unexplained = find_unexplained(measured.segments, selection.fit, measured.noise, geometry,
                                   out_dir / FIGURE_FILE if options.figures else None, measured.flights)
    noise_floor = None
    if predictions:
        floor_by_horizon = prediction_floor(starts, models[final_label][1], measured.noise, options.seed)
        noise_floor = {f"median_error_mm_{h:g}s".replace("0.", "0_"): round(float(v) * 1000, 2)
                       for h, v in zip(HORIZONS, floor_by_horizon)}
        unexplained = unexplained_predictions(predictions.errors[final_label], floor_by_horizon, measured.noise,
                                              final_label) + unexplained
    progress("fitting a smooth surface correction to what the named effects leave")
    surface = surface_correction.fit_surface_correction(measured.segments, selection.fit, measured.noise, geometry, options.seed)
    if surface is not None and surface.reported:
        figure = surface_correction.FIGURE_FILE if options.figures else None
        if figure:
            surface_correction.draw(surface, geometry, out_dir / figure)
        unexplained.append(surface.entry(measured.noise, geometry, figure))
    table_e = restitution.coefficient if restitution.coefficient is not None else nominal_e
    wall_stretches = wall_segments.check_stretches(restitution, table_e, geometry, options.seed)
    unexplained += wall_segments.unexplained_entries(wall_stretches, measured.noise)

    report_effects = []
    for effect in effects:
        evidence = (restitution.evidence if effect["name"] == "wall_restitution" else selection.evidence.get(effect["name"], {}))
        report_effects.append({**effect, "evidence": evidence, "description": describe(effect, nominal_rolling, nominal_e)})
    if game is not None:
        report_effects += game.effects()
    if rods is not None:
        report_effects += [{**e, "description": rod_report.describe(e)} for e in rods.effects]
    report = {
        "effects": report_effects,
        "baseline": baseline,
        "calibrated": calibrated,
        "params_file": str(params_file.resolve()),
        "unexplained": unexplained,
        "noise_floor": noise_floor,
        "not_checked": not_checked(rods is not None, encoders is not None, camera_game),
        "rejected": _rejected(selection, restitution, rods, game),
        # The generic correction, outside the vocabulary: tried on every ball, reported under `unexplained` only with
        # a held-out gain; it changes neither the calibrated file nor the `calibrated` errors.
        "surface_correction": surface.summary() if surface is not None else None,
        "wall_stretches": wall_stretches,  # each stretch of wall with enough bounces: its own restitution and gain
        "data": {
            "bag": bag, "detections": int(len(t)), "duration_s": round(float(t[-1] - t[0]), 2),
            "tracks": len(measured.tracks), "rolling_segments": len(measured.segments),
            "bounces_used": len(restitution.windows), "noise_mm": round(measured.noise * 1000, 2),
            "camera_only_game": camera_game, "hidden_touch_cuts": hidden_cuts,
        },
        "method": {
            "selection": "forward selection; an effect is named when its held-out error drop (2 alternating folds of segments) exceeds "
                         "30 noise variances and it is materially large; a dent is judged on the rolls that cross it, each "
                         "predicted by the others (30), or where too few cross it, on alternate frames (60)",
            "segments": "rolling segments, and the slide after each wall bounce with its slip fitted per segment",
            "horizons_s": list(HORIZONS),
            "physics": "wall bounces and the 1 s predictions roll the ball-only table on the 20 kHz reference physics, whose "
                       "mj_step alone is the whole physics, so mujoco.rollout runs them on threads; the fast physics needs its "
                       "impact rule between steps. Figure bounces replay the whole table on the fast physics, as the "
                       "simulation runs it. The calibrated file runs on either (solver.physics)",
            "calibrated_predictions": "cross-fitted: each start predicted by the model fitted on the other fold of segments",
            "unexplained": f"a place (all the rolling data, a cell of the field, a speed band, the first 0.3 s after a wall bounce or a "
                           f"figure contact) whose residual RMS per axis is over {FAR_ABOVE:g} x the detection noise, or held-out "
                           f"predictions 1 s ahead over {FAR_ABOVE:g} x the noise floor (the error a right model makes from the "
                           f"detection noise alone, `noise_floor`)",
        },
    }
    if options.figures:
        progress("drawing figures")
        figures.residual_map(measured, geometry, theta_nominal, effects, out_dir / "residual_map.png")
        figures.deceleration_vs_speed(measured, nominal_rolling, selection.fit.theta, out_dir / "deceleration_vs_speed.png")
        figures.wall_bounces(measured, nominal_e, restitution.coefficient, out_dir / "wall_bounces.png")
        if predictions:
            figures.tracks_overlay(measured, geometry, predictions, out_dir / "tracks.png")
        report["figures"] = [p.name for p in sorted(out_dir.glob("*.png"))]
    if rods is not None:
        report["rods"] = rods.block
    if game is not None:
        report["camera"], report["figure_bounces"] = game.camera.block, game.figures.block
    if floor is not None:
        report["floor"] = floor
    report["runtime_s"] = round(time.monotonic() - started, 1)
    # CPU seconds of all this process's threads: with nothing else running the wall time is at most
    # this. It is no load-free figure: on this machine's two shared cores it grew with the others'
    # load too (one trial 39 -> 67 s).
    report["cpu_s"] = round(time.process_time() - cpu_started, 1)
    (out_dir / "report.json").write_text(json.dumps(report, indent=2, default=_plain))
    rods_section = rod_report.markdown(rods.block, rods.effects) if rods is not None else ""
    (out_dir / "report.md").write_text(markdown(report, nominal_rolling, nominal_e) + rods_section)
    return report


def _judge_gains(measured, selection, theta_base, seed, progress, min_duration: float = 0.0) -> None:
    """Nothing named without a held-out gain (table_gain): a named rolling effect that does not lower the ball's held-out
    error on the data it touches, alone and in the final set, moves to `selection.rejected` with its gain, its
    parameters back at the base table's (the others are not refitted)."""
    def build(subset):
        return [_without(theta, [n for n in selection.effects if n not in subset], theta_base) for theta in selection.fold_theta]

    _, gains, refused = table_gain.judge(measured.segments, build, list(selection.effects), seed, progress, min_duration)
    for name, evidence in refused.items():
        selection.rejected[name] = {**selection.evidence.pop(name, {}), **evidence}
        selection.effects.remove(name)
        selection.fold_theta = [_without(theta, [name], theta_base) for theta in selection.fold_theta]
    if refused:  # the rest refitted on all the data without what was refused
        theta = _without(selection.fit.theta, list(refused), theta_base)
        selection.fit = fit(SegmentBatch(measured.segments), free_indices(selection.effects), theta, selection.fit.states)
    for name, gain in gains.items():
        selection.evidence.setdefault(name, {})["gain"] = gain


def not_checked(drives: bool, encoders: bool, camera_game: bool = False) -> list[str]:
    """What a recording without rod encoders or commands (a camera alone) does not let calibrate check."""
    out = []
    if not drives:
        out.append("the rod drives (rod_latency, rod_speed_limit, rod_acceleration_limit): no /joint_states with both "
                   "teams' rod commands")
    if not encoders:
        out += ["camera_latency: no /joint_states to time the ball's touches of the figures against",
                "figure_restitution: no /joint_states to pose the figures",
                "figure contacts: inferred from the ball's path alone (sudden velocity changes near a rod line), so a "
                "touch that hardly changes the ball's velocity may stay inside a rolling segment" +
                (f"; in this game a segment better fitted as two rolls was cut, and each table effect's gain is judged on "
                 f"free stretches of {table_gain.CAMERA_ONLY_MIN_STRETCH:g} s or more only" if camera_game else "")]
    return out


def _rejected(selection, restitution, rods, game=None) -> dict:
    """The report's `rejected`: candidates tried and not named, with their evidence (and the gain rule's reason)."""
    out = {} if restitution is None or restitution.coefficient is not None else {"wall_restitution": restitution.evidence}
    out.update(selection.rejected if selection is not None else {})
    if game is not None:  # a game's camera latency and figure restitution, fitted and not named
        for name, finder in (("camera_latency", game.camera), ("figure_restitution", game.figures)):
            if not finder.effects and "gain" in finder.evidence:
                out[name] = finder.evidence
    for effect in (rods.refused if rods is not None else []):
        entry = {"params": effect["params"], **effect["evidence"]}
        if effect["name"] in out:  # another drive selection refused under the same name
            out[effect["name"]].setdefault("also", []).append(entry)
        else:
            out[effect["name"]] = entry
    return out


def _without(theta: np.ndarray, names: list[str], theta_base: np.ndarray) -> np.ndarray:
    """theta with the parameters of `names` back at the base table's."""
    out = theta.copy()
    for name in names:
        idx = list(surrogate.EFFECT_PARAMS[name])
        out[idx] = theta_base[idx]
    return out


def _plain(value):
    """numpy scalars and arrays as JSON values."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"{type(value).__name__} is not JSON serializable")


def _unexplained_text(u: dict) -> str:
    """One unexplained place in words; a generic correction (outside the vocabulary) with what it would bring."""
    if u.get("kind") == "surface_height_map":
        g = u["gain"]["held_out_error_mm"]
        lo, hi = g["ci95_drop"]
        return (f"{u['where']}: a generic correction, no cause named; on held-out rolls it would bring the error from "
                f"{g['without']:.2f} to {g['with']:.2f} mm (drop 95 % [{lo:.3f}, {hi:.3f}] mm; noise {u['noise_mm']:.2f} mm)")
    if u.get("kind") == "wall_stretch_restitution":
        g = u["gain"]["bounce_replay_error_mm"]
        lo, hi = g["ci95_drop"]
        return (f"{u['where']}: no cause named; its own coefficient would bring the held-out bounces' replay error from "
                f"{g['without']:.2f} to {g['with']:.2f} mm (drop 95 % [{lo:.3f}, {hi:.3f}] mm)")
    return f"{u['where']}: {u['residual_mm']:.1f} mm against {u['noise_mm']:.1f} mm ({u['ratio']:.1f}x)"


def plain_summary(report: dict) -> str:
    lines = []
    unexplained = report.get("unexplained") or []
    if report["effects"]:
        lines.append(f"The nominal simulation gets this table wrong in {len(report['effects'])} way(s):")
        for e in report["effects"]:
            lines.append(f"  - {e['name']}: {e['description']}")
    elif unexplained:
        lines.append("No effect of the vocabulary is supported by held-out evidence, and the nominal simulation does NOT "
                     "explain the data:")
    else:
        lines.append(f"The nominal simulation explains the data: no effect is supported by held-out evidence, and its residuals "
                     f"are within {FAR_ABOVE:g}x the noise everywhere they were judged.")
    if unexplained:
        if report["effects"]:
            lines.append(f"The calibrated model still misses by far more than the noise in {len(unexplained)} place(s):")
        for u in unexplained[:6]:
            lines.append(f"  ! {_unexplained_text(u)}")
        if len(unexplained) > 6:
            lines.append(f"  ! and {len(unexplained) - 6} more (report.json `unexplained`)")
    b, c = report["baseline"], report["calibrated"]

    def fmt(block, key):
        v = block.get(f"median_error_mm_{key}")
        ci = block.get(f"ci95_mm_{key}")
        return "n/a" if v is None else (f"{v:.1f} mm" + (f" [{ci[0]:.1f}, {ci[1]:.1f}]" if ci else ""))

    lines.append(f"Median position error on held-out starts ({b.get('starts', 0)} starts), nominal -> calibrated:")
    for key, label in (("0_25s", "0.25 s"), ("0_5s", "0.5 s"), ("1s", "1 s")):
        ratio = ""
        if b.get(f"median_error_mm_{key}") and c.get(f"median_error_mm_{key}"):
            ratio = f"  ({b[f'median_error_mm_{key}'] / c[f'median_error_mm_{key}']:.1f}x better)" if report["effects"] else ""
        lines.append(f"  {label:>6} ahead: {fmt(b, key)} -> {fmt(c, key)}{ratio}")
    rods = report.get("rods")
    if rods:
        b, c = rods.get("baseline", {}), rods.get("calibrated", {})
        for axis, unit, label in (("slide", "mm", "slides"), ("rotate", "deg", "rotations")):
            key = f"{axis}_median_error_{unit}_0_25s"
            if b.get(key) is not None and c.get(key) is not None:
                lines.append(f"Rod drives, {label}: joint-position error 0.25 s ahead {b[key]:.2f} -> {c[key]:.2f} {unit} "
                             f"(held-out, {c.get('starts', '?')} starts)")
    if report.get("ball_skipped"):
        lines.append(f"The ball was NOT calibrated: {report['ball_skipped']}")
    for item in report.get("not_checked") or []:
        lines.append(f"Not checked: {item}")
    lines.append(f"Calibrated model: {report['params_file']}")
    return "\n".join(lines)


def markdown(report: dict, nominal_rolling: float, nominal_e: float) -> str:
    d = report["data"]
    out = ["# Calibration report", "",
           f"Data: {d['detections']} detections over {d['duration_s']} s, {d['tracks']} tracks, "
           f"{d['rolling_segments']} rolling segments, {d['bounces_used']} bounces used, noise {d['noise_mm']} mm.", "",
           "## What the simulation gets wrong, and why", ""]
    unexplained = report.get("unexplained") or []
    if report["effects"]:
        out += [f"- **{e['name']}**: {e['description']} (held-out evidence: "
                f"{e['evidence'].get('held_out_error_drop_noise_variances', 'n/a')} noise variances; held-out gain: "
                f"{effect_gain.describe(e['evidence'].get('gain'))})" for e in report["effects"]]
    elif unexplained:
        out.append("No candidate earned held-out evidence, but the nominal model does **not** explain the data (below).")
    else:
        out.append("Nothing: the nominal model explains the data (no candidate earned held-out evidence, and the residuals are "
                   f"within {FAR_ABOVE:g}x the noise everywhere they were judged).")
    if unexplained:
        out += ["", "## Where the model still misses by far more than the noise", "",
                "| where | residual (mm) | noise (mm) | ratio |", "|---|---|---|---|"]
        out += [f"| {u['where']} | {u['residual_mm']} | {u['noise_mm']} | {u['ratio']} |" for u in unexplained]
        out += ["", f"![unexplained]({FIGURE_FILE})" if report.get("figures") else ""]
        out += [f"- {_unexplained_text(u)}" + (f" ![{u['kind']}]({u['figure']})" if u.get("figure") else "")
                for u in unexplained if u.get("kind") in ("surface_height_map", "wall_stretch_restitution")]
    if report.get("not_checked"):
        out += ["", "## What this recording did not let calibrate check", ""] + [f"- {item}" for item in report["not_checked"]]
    if report.get("rejected"):
        out += ["", "Candidates tried and not named:", ""]
        out += [f"- {k}: {v}" for k, v in report["rejected"].items()]
    out += ["", "## The gain (median position error on held-out starts, 95 % bootstrap interval)", "",
            "| horizon | nominal (mm) | calibrated (mm) |", "|---|---|---|"]
    for key, label in (("0_25s", "0.25 s"), ("0_5s", "0.5 s"), ("1s", "1 s")):
        b, c = report["baseline"], report["calibrated"]
        out.append(f"| {label} | {b.get(f'median_error_mm_{key}')} {b.get(f'ci95_mm_{key}', '')} | "
                   f"{c.get(f'median_error_mm_{key}')} {c.get(f'ci95_mm_{key}', '')} |")
    out += ["", f"Calibrated parameter file: `{report['params_file']}`", "", "## Figures", ""]
    for name in report.get("figures", []):
        out.append(f"![{name}]({name})")
    out.append("")
    return "\n".join(out)
