"""The drive effects' gain rule (foos_calibration.drive_gain) on bang-bang games, where a drive effect can gain only
beside another: every command at a limit, so drives without a speed limit run far past a hidden one, and a rate limit
on the way up to that speed hardly moves where they are 0.25 s later.

"Alone" is the effect added to what its drives are given by the effects that have passed the check before it
(latency, then speed, then acceleration limits), so the acceleration limit is judged beside the speed limit it acts
behind; one that passed on nominal drives only (the former rule) refused it (the styled bench's trial 16:
docs/measurements/calibration-2026-11-28-bench-3.md). And an effect is still judged against nominal where the one it
would sit behind fails: offered as candidates on a game with nothing hidden, the pair is refused.

An effect that fails alone is judged again beside what has passed since: on the robot table's drives a latency judged
first, against nominal drives that run far past a hidden speed limit, gains only beside that limit.
"""
from __future__ import annotations

from foos_calibration.drive_gain import judge_gains
from foos_calibration.game_data import drive_model
from foos_calibration.game_styles import GameStyle
from foos_calibration.games import GameOptions, play
from foos_calibration.rods import DriveData, identify, limits_of, prediction_errors
from foos_core.names import TEAMS
from foos_core.table_params import ROBOT_PARAMS_FILE, SERVO_PARAMS_FILE, load_params

DURATION = 30.0  # s of game
# Trial 16's hidden pair (bench_calibration --games --styles --seed 1000), on every drive.
SPEED = {"name": "rod_speed_limit", "params": {"slide": 1.02, "rotate": 18.9}}
ACCELERATION = {"name": "rod_acceleration_limit", "params": {"slide": 31.9, "rotate": 1486.0}}


def bang_bang_game(effects: list[dict], seed: int) -> tuple[DriveData, object]:
    """A game on the former servo drives, both teams sending every command at a limit, every 10 ms. Pinned to them: on the
    robot's jerk-limited drives (the default since 29 Nov) a hidden 1486 rad/s^2 takes 40 ms to reach under their
    36650 rad/s^3, by when the rotation has passed the hidden 18.9 rad/s, so that acceleration limit does not show."""
    params = load_params(SERVO_PARAMS_FILE)
    style = GameStyle(players=("bang_bang", "bang_bang"), encoder_rate=500.0, fps=60.0, control_period=0.01,
                      transport_delay=0.0, transport_jitter=0.0, stamps="arrival", encoder_drop=0.0, encoder_bursts=0.0,
                      occlusion_bursts=0.0, hide_under_figures=False, seed=seed)
    recording = play(effects, GameOptions(duration=DURATION, seed=seed, fps=style.fps, encoder_rate=style.encoder_rate),
                     params=params, style=style)
    data = DriveData(recording.joint_t, recording.joint_position, recording.joint_velocity,
                     {team: recording.command_t for team in TEAMS}, recording.commands)
    return data, drive_model(params)


# On these 30 s games the common rotation limit comes out 14 % high (1698 rad/s^2: ramps of 13 ms under commands 10 ms
# apart), and per-rod rotation limits of 2245-2267 rad/s^2 are tried as well (and refused: they gain nothing on top).
# With the former rule (alone = nominal -> nominal + it) the common acceleration limit was refused too, its alone
# interval including zero; seeds 5 and 16 the same.
def test_a_rate_limit_behind_a_speed_clip_is_judged_beside_it():
    data, model = bang_bang_game([SPEED, ACCELERATION], seed=3)
    result = identify(data, model)
    common = {e["name"]: e for e in result.effects if "team" not in e["params"]}
    assert sorted(common) == ["rod_acceleration_limit", "rod_speed_limit"], (result.effects, result.refused)
    for name, hidden, tolerance in (("rod_speed_limit", SPEED, 0.08), ("rod_acceleration_limit", ACCELERATION, 0.2)):
        found = common[name]["params"]
        assert all(abs(found[axis] - v) <= tolerance * v for axis, v in hidden["params"].items()), (name, found)
    gain = common["rod_acceleration_limit"]["evidence"]["gain"]
    assert gain["alone_with"] == ["rod_speed_limit"], gain
    assert common["rod_speed_limit"]["evidence"]["gain"]["alone_with"] == [], common["rod_speed_limit"]["evidence"]["gain"]
    for part in ("alone", "in_final_set"):
        for block in gain[part].values():
            assert block["ci95_drop"][0] > 0, gain


def test_a_limit_offered_beside_a_false_one_is_still_judged_against_nominal():
    """Nothing hidden: the trial-16 pair offered to the rule as if the selection had named it. The speed limit makes the
    held-out joint error worse on its own, so it does not pass alone, and the acceleration limit is judged against
    nominal, not beside it: both are refused."""
    data, model = bang_bang_game([], seed=17)
    effects = [{**SPEED, "evidence": {}}, {**ACCELERATION, "evidence": {}}]
    kept, folds, refused = judge_gains(lambda fold_sets: prediction_errors(data, model, [limits_of(e) for e in fold_sets]),
                                       effects, [[SPEED, ACCELERATION], [SPEED, ACCELERATION]])
    assert kept == [] and folds == [[], []], kept
    assert sorted(e["name"] for e in refused) == ["rod_acceleration_limit", "rod_speed_limit"], refused
    for effect in refused:
        gain = effect["evidence"]["gain"]
        assert gain["alone_with"] == [] and "no held-out gain" in effect["evidence"]["reason"], gain
        assert any(block["ci95_drop"][0] <= 0 for block in gain["alone"].values()), gain


def test_a_bang_bang_game_with_nothing_hidden_names_no_drive_effect():
    data, model = bang_bang_game([], seed=17)
    result = identify(data, model)
    assert result.effects == [], result.effects


# The robot-table bench's trial 12 (docs/measurements/calibration-2026-11-28-robot-bench-5.md): a 52 ms latency with a
# 1.05 m/s, 27.6 rad/s speed limit. Judged first, against nominal jerk-limited drives that run to 314 rad/s, the latency
# gains nothing (on this game 72.8 -> 76.1 mm, 95 % [-14.9, 8.4]; 1160 -> 1149 deg, [-58.6, 25.2]) and was refused while
# the speed limit passed; the calibrated drives stayed 43 mm and 49 deg off 0.25 s ahead. Judged again beside the speed
# limit it passes: 1.2 mm and 6.7 deg.
def test_a_latency_that_gains_only_beside_a_speed_limit_is_judged_again_beside_it():
    params = load_params(ROBOT_PARAMS_FILE)
    hidden = [{"name": "rod_latency", "params": {"delay": 0.052}},
              {"name": "rod_speed_limit", "params": {"slide": 1.05, "rotate": 27.6}}]
    recording = play(hidden, GameOptions(duration=DURATION, seed=11), params=params)
    data = DriveData(recording.joint_t, recording.joint_position, recording.joint_velocity,
                     {team: recording.command_t for team in TEAMS}, recording.commands)
    result = identify(data, drive_model(params))
    found = {e["name"]: e for e in result.effects}
    assert sorted(found) == ["rod_latency", "rod_speed_limit"], (result.effects, result.refused)
    assert abs(found["rod_latency"]["params"]["delay"] - 0.052) <= 0.005, found["rod_latency"]["params"]
    assert found["rod_latency"]["evidence"]["gain"]["alone_with"] == ["rod_speed_limit"], found["rod_latency"]["evidence"]["gain"]
    assert all(abs(found["rod_speed_limit"]["params"][axis] - v) <= 0.08 * v for axis, v in hidden[1]["params"].items()), \
        found["rod_speed_limit"]["params"]
