"""Whether a game's data shows a hidden drive effect, decided from the truth before any fit: the identification's
rules applied to the true values. An axis of an effect shows where its true value is material (foos_calibration.rods'
materiality, on the commands sent) and, with `truth` given, where the true model earns the held-out gain the naming
rule asks for (foos_calibration.drive_gain: the joint positions 0.25 s ahead with all the hidden drive effects against
all but this one, the 95 % interval of the drop above zero). The game bench and the rod tests use it to tell an
effect the fit missed from one the data never showed (an acceleration limit above what the commands ever demand of
the drives, or one that hardly moves them)."""
from __future__ import annotations

import numpy as np

from foos_core.names import AXES, COMMAND_SIZE, JOINT_NAMES

from . import drive_gain, effect_gain, rods


def material_accelerations(data: rods.DriveData, model: rods.DriveModel) -> np.ndarray:
    """(16,) the highest acceleration limit that is material on each drive of this game (the identification's rule,
    for judging a hidden limit from the truth): rods.MATERIAL_ACCEL of the servo's own acceleration, or on the jerk-limited
    drives rods.MATERIAL_PROFILE_ACCEL of the highest acceleration their nominal S-curves reach on the commands sent."""
    return np.concatenate([team.material_accel for team in rods._teams(data, model)])


def shown_axes(effect: dict, data: rods.DriveData, model: rods.DriveModel, truth: list[dict] | None = None) -> list[str]:
    """The axes on which a game's data shows a hidden drive effect: the identification's materiality applied to the
    true value and the commands sent, on more than half of the drives the effect acts on (as `combine` names an effect
    for all drives); a latency shows on both axes or neither. With `truth` (all the hidden drive effects, `effect`
    among them), only the axes where the true model also earns a held-out gain (true_gain_axes)."""
    p = effect["params"]
    if effect["name"] == "rod_latency":
        shown = list(AXES) if p["delay"] >= rods.MATERIAL_DELAY else []
        return [a for a in shown if truth is None or a in true_gain_axes(effect, truth, data, model)] if shown else []
    material = material_accelerations(data, model)
    shown = []
    for axis in (a for a in AXES if a in p):
        drives = [j for j, name in enumerate(JOINT_NAMES) if name.endswith("_" + axis)
                  and (not p.get("team") or name.startswith(f"{p['team']}_"))
                  and (not p.get("rod") or name.split("_")[1] == p["rod"])]
        if effect["name"] == "rod_speed_limit":
            asked = [np.abs(data.commands[JOINT_NAMES[j].split("_")[0]][:, j % COMMAND_SIZE]).max() for j in drives]
            hits = [p[axis] <= rods.MATERIAL_SPEED * a for a in asked]
        else:
            hits = [p[axis] <= material[j] for j in drives]
        if sum(hits) > len(drives) / 2:
            shown.append(axis)
    return [a for a in shown if truth is None or a in true_gain_axes(effect, truth, data, model)] if shown else []


def true_gain_axes(effect: dict, truth: list[dict], data: rods.DriveData, model: rods.DriveModel) -> set[str]:
    """The axes on which the true model gains from `effect`: the held-out joint position error 0.25 s ahead of the
    drives it acts on, with every hidden drive effect against all but this one (drive_gain's interval rule)."""
    others = [e for e in truth if e is not effect]
    with_it = rods.prediction_errors(data, model, [rods.limits_of(truth)] * 2)
    without = rods.prediction_errors(data, model, [rods.limits_of(others)] * 2)
    drives = drive_gain.acts_on([effect], [])
    blocks = drive_gain.axis_gains(without[0], with_it[0], drives, with_it[1], seed=0)
    return {key.split("_")[0] for key, block in blocks.items() if effect_gain.excludes_zero(block)}
