"""The nominal drives' position prediction (rods.prediction_errors), on the robot table's jerk-limited drives and on the
velocity servos.

The truth is foos_sim's own generator (drive_profiles.ProfileDrives, the drives of TableSimulation) fed each command at
its exact arrival and integrated on 20 us steps at the setpoint of each step's middle, sampled like encoders at 123 Hz
without noise. Commands come every 1.2-2.8 ms (a 500 Hz controller with transport jitter), so two can fall due within
one 2 ms step of foos_sim.drive_limits.predict_positions, which then drops the first (that predictor was 0.5-1.8 rad
off 0.25 s ahead here); and the rods turn at up to thousands of rad/s^2, so a position read off the straight line
between two samples 8 ms apart is mrad off (the predictions are scored at the sample nearest each horizon).

The velocity servos' truth (on the reference physics' table) is their servo law itself, force kv (command - velocity)
clipped to the force limit, integrated on 2 us steps from each command's arrival: predict_positions' implicit 2 ms
steps put the rotations 0.04-0.12 rad off 0.25 s ahead there.
"""
from __future__ import annotations

import numpy as np

from foos_calibration.game_data import drive_model
from foos_calibration.rods import HORIZONS, DriveData, limits_of, prediction_errors
from foos_core.names import COMMAND_SIZE, JOINT_NAMES, TEAMS
from foos_core.table_params import ROBOT_PARAMS_FILE, SERVO_REFERENCE_PARAMS_FILE, load_params
from foos_sim.drive_profiles import ProfileDrives, profile_limits

STEP = 2e-5  # s: the truth's integration step
DURATION = 2.0  # s
ENCODER_RATE = 123.0  # Hz


def _noisy_commands(rng: np.random.Generator, limits: np.ndarray, step: float) -> tuple[np.ndarray, np.ndarray]:
    """Steps of `step` at which commands arrive, 1.2-2.8 ms apart, and the (K, 16) commands: a slow wander plus 500 Hz
    noise within the limits (8,), the slides wandering alone at a tenth of their limit."""
    gaps = np.round(rng.uniform(0.0012, 0.0028, size=int(DURATION / 0.0012)) / step).astype(int)
    command_steps = np.cumsum(gaps)
    command_steps = command_steps[command_steps * step < DURATION - 0.01]
    wander = np.cumsum(rng.normal(0.0, 0.02, size=(len(command_steps), 2 * COMMAND_SIZE)), axis=0)
    commands = np.clip((np.tanh(wander) * 0.3 + rng.normal(0.0, 0.1, size=wander.shape)) * np.tile(limits, 2), -np.tile(limits, 2),
                       np.tile(limits, 2))
    # The slides wander alone, slowly: under 500 Hz noise of a few cm/s their S-curves keep arriving at their targets,
    # where a plan's peak acceleration is the square root of the velocity to gain, and a rounding difference between
    # two exact implementations of the same generator (the model's recurrence and ProfileDrives) grew from 1e-7 to
    # 2e-2 m/s in 0.1 s.
    slides = np.array([name.endswith("_slide") for name in JOINT_NAMES])
    commands[:, slides] = 0.1 * np.tanh(wander[:, slides]) * np.tile(limits, 2)[slides]
    return command_steps, commands


def _as_data(samples_t, samples_p, samples_v, stamps, commands) -> DriveData:
    return DriveData(np.array(samples_t), np.array(samples_p), np.array(samples_v), {team: stamps for team in TEAMS},
                     {team: commands[:, i * COMMAND_SIZE:(i + 1) * COMMAND_SIZE] for i, team in enumerate(TEAMS)})


def _speed_limits(params: dict) -> np.ndarray:
    return np.array([float(params["rods"]["slide_speed_limit"]), float(params["rods"]["rotate_speed_limit"])] * 4)


def _fast_noisy_game(seed: int = 3) -> DriveData:
    params = load_params(ROBOT_PARAMS_FILE)
    # Commands on the truth's step grid (so each acts exactly when stamped).
    command_steps, commands = _noisy_commands(np.random.default_rng(seed), _speed_limits(params), STEP)
    drives = ProfileDrives(profile_limits(params), None)
    steps = int(DURATION / STEP)
    every = int(round(1.0 / (ENCODER_RATE * STEP)))
    position, velocity = np.zeros(len(JOINT_NAMES)), np.zeros(len(JOINT_NAMES))
    samples_t, samples_p, samples_v = [], [], []
    next_command = 0
    for k in range(steps):
        time = k * STEP
        while next_command < len(command_steps) and command_steps[next_command] <= k:
            for team in range(len(TEAMS)):
                drives.receive(time, team, commands[next_command, team * COMMAND_SIZE:(team + 1) * COMMAND_SIZE])
            next_command += 1
        targets = drives.targets(time, STEP)
        if targets is not None:
            velocity = np.array(targets, dtype=float)
        position = position + velocity * STEP
        if (k + 1) % every == 0:
            samples_t.append((k + 1) * STEP)
            samples_p.append(position.copy())
            samples_v.append(drives.state((k + 1) * STEP)[0])
    return _as_data(samples_t, samples_p, samples_v, command_steps * STEP, commands)


def test_jerk_limited_prediction_acts_on_every_command_and_scores_at_samples():
    data = _fast_noisy_game()
    model = drive_model(load_params(ROBOT_PARAMS_FILE))
    nominal = limits_of([])
    errors, _ = prediction_errors(data, model, [nominal, nominal])
    slides = np.array([name.endswith("_slide") for name in JOINT_NAMES])
    rotations = errors[:, HORIZONS.index(0.25)][:, ~slides]
    assert np.isfinite(rotations).all() and len(rotations) >= 5
    # Exact but for the truth's own 20 us integration (the fast physics' half-step lag of the model's velocity is
    # the same at the start and at the horizon): within 0.3 mrad, a tenth of the encoder noise.
    assert np.max(rotations) < 3e-4, np.max(rotations, axis=0)
    slide_errors = errors[:, HORIZONS.index(0.25)][:, slides]
    assert np.nanmax(slide_errors) < 2e-5


SERVO_STEP = 2e-6  # s: the servo truth's integration step


def _servo_noisy_game(seed: int = 4) -> tuple[DriveData, object]:
    params = load_params(SERVO_REFERENCE_PARAMS_FILE)  # the servos as the reference resolves them: their own law
    model = drive_model(params)
    assert model.continuous
    servo = model.servo
    command_steps, commands = _noisy_commands(np.random.default_rng(seed), _speed_limits(params), SERVO_STEP)
    every = int(round(1.0 / (ENCODER_RATE * SERVO_STEP)))
    position, velocity, goal = np.zeros(len(JOINT_NAMES)), np.zeros(len(JOINT_NAMES)), np.zeros(len(JOINT_NAMES))
    samples_t, samples_p, samples_v = [], [], []
    due = np.zeros(int(DURATION / SERVO_STEP) + 1, dtype=int) - 1
    due[command_steps] = np.arange(len(command_steps))
    for k in range(int(DURATION / SERVO_STEP)):
        if due[k] >= 0:
            goal = commands[due[k]]
        force = np.clip(servo.gain * (goal - velocity), -servo.force_limit, servo.force_limit)
        velocity = velocity + force / servo.inertia * SERVO_STEP
        position = position + velocity * SERVO_STEP
        if (k + 1) % every == 0:
            samples_t.append((k + 1) * SERVO_STEP)
            samples_p.append(position.copy())
            samples_v.append(velocity.copy())
    return _as_data(samples_t, samples_p, samples_v, command_steps * SERVO_STEP, commands), model


def test_servo_prediction_follows_the_servo_law_between_commands():
    data, model = _servo_noisy_game()
    nominal = limits_of([])
    errors, _ = prediction_errors(data, model, [nominal, nominal])
    slides = np.array([name.endswith("_slide") for name in JOINT_NAMES])
    at = errors[:, HORIZONS.index(0.25)]
    assert np.isfinite(at[:, ~slides]).all() and len(at) >= 5
    # Within a tenth of the encoder noise (3 mrad, 0.2 mm): the truth's own 2 us Euler steps are what is left.
    assert np.max(at[:, ~slides]) < 3e-4, np.max(at[:, ~slides], axis=0)
    assert np.nanmax(at[:, slides]) < 2e-5, np.nanmax(at[:, slides], axis=0)
