"""Acceptance physics of the shipped model, on both physics (fast and the 20 kHz reference): rolling,
tilt, wall and figure bounces, containment, kicks, goals."""
import copy
import math
from concurrent.futures import ProcessPoolExecutor

import mujoco
import numpy as np
import pytest

from foos_core.names import BALL_JOINT, JOINT_NAMES
from foos_core.table_params import SERVO_PARAMS_FILE, load_params
from foos_sim.model_builder import PHYSICS
from foos_sim.simulation import TableSimulation

from .helpers import figure_bounce, launch, sample_period, wall_bounce

G = 9.81
NOMINAL = load_params()
ROLLING_DECELERATION = NOMINAL["ball"]["rolling_deceleration"]
WALL_RESTITUTION = NOMINAL["walls"]["restitution"]
FIGURE_RESTITUTION = NOMINAL["figures"]["restitution"]


def speed_history(sim, seconds, stop_margin=0.03):
    """(t, planar speed, position) sampled while the ball rolls clear of the walls."""
    ts, speeds, positions = [], [], []
    period = sample_period(sim)
    for _ in range(int(seconds / period)):
        sim.advance(period)
        p = sim.ball_position()
        if abs(p[0]) > sim.half_width - sim.ball_radius - stop_margin or abs(p[1]) > sim.half_length - sim.ball_radius - stop_margin:
            break
        ts.append(sim.time)
        speeds.append(np.linalg.norm(sim.ball_velocity()[:2]))
        positions.append(p[:2])
    return np.array(ts), np.array(speeds), np.array(positions)


def fitted_deceleration(ts, speeds, settle=0.02, floor=0.03):
    keep = (ts > settle) & (speeds > floor)
    assert keep.sum() > 10, "too short a roll to fit"
    return -np.polyfit(ts[keep], speeds[keep], 1)[0]


@pytest.mark.parametrize("speed", [0.4, 1.2, 2.5])
@pytest.mark.parametrize("heading_deg", [0, 60, 90, 135, 225, 300])
def test_rolling_ball_decelerates_at_the_nominal_rolling_resistance(table, speed, heading_deg):
    heading = math.radians(heading_deg)
    direction = np.array([math.cos(heading), math.sin(heading)])
    # Start near the wall behind the ball, so the roll is long.
    start = -direction * np.array([0.28, 0.5])
    launch(table, start, speed * direction)
    ts, speeds, _ = speed_history(table, 3.0)
    deceleration = fitted_deceleration(ts, speeds)
    assert deceleration == pytest.approx(ROLLING_DECELERATION, rel=0.05)
    # Coulomb, not viscous: the same deceleration in the fast and the slow half of the roll.
    keep = (ts > 0.02) & (speeds > 0.03)
    half = keep.sum() // 2
    if half > 10:
        fast = -np.polyfit(ts[keep][:half], speeds[keep][:half], 1)[0]
        slow = -np.polyfit(ts[keep][half:], speeds[keep][half:], 1)[0]
        assert fast == pytest.approx(slow, rel=0.05)


@pytest.mark.parametrize("spin", [30.0, 60.0])
def test_spin_about_the_vertical_does_not_change_the_rolling_resistance(table, spin):
    """A wall's friction leaves the ball spinning about the vertical (about 25 rad/s per m/s of normal
    speed). With MuJoCo's elliptic cone, spin and rolling friction share one budget, so a large spin
    friction made a spinning ball roll up to a third more freely; the shipped model keeps it minimal."""
    launch(table, np.array([0.0, -0.45]), np.array([0.0, 0.5]))
    ball_dofs = table.model.jnt_dofadr[mujoco.mj_name2id(table.model, mujoco.mjtObj.mjOBJ_JOINT, BALL_JOINT)]
    table.data.qvel[ball_dofs + 5] = spin  # free joint: angular velocity in the body frame, upright at reset
    mujoco.mj_forward(table.model, table.data)
    ts, speeds, _ = speed_history(table, 1.5)
    assert fitted_deceleration(ts, speeds) == pytest.approx(ROLLING_DECELERATION, rel=0.03)


def tilted_sim(slope_x, slope_y, physics):
    params = copy.deepcopy(NOMINAL)
    params["effects"] = [{"name": "table_tilt", "params": {"slope_x": slope_x, "slope_y": slope_y}}]
    return TableSimulation(params=params, physics=physics)


@pytest.mark.parametrize("physics", PHYSICS)
@pytest.mark.parametrize("slope", [0.03, 0.05])
@pytest.mark.parametrize("heading_deg", [0, 90, 225])
def test_tilted_gravity_drifts_a_resting_ball_at_five_sevenths_g_s(slope, heading_deg, physics):
    """Released at rest, the ball rolls downhill at 5/7 g s less the Coulomb rolling resistance.

    Only slopes steeper than the resistance (5/7 g s > 0.15 m/s^2, s > 0.021) move a resting ball;
    gentler slopes are measured between uphill and downhill rolls in the next test.
    """
    heading = math.radians(heading_deg)
    sim = tilted_sim(slope * math.cos(heading), slope * math.sin(heading), physics)
    launch(sim, (0.0, 0.0), (0.0, 0.0))
    ts, speeds, positions = speed_history(sim, 2.0)
    keep = ts > 0.02
    acceleration = np.polyfit(ts[keep], speeds[keep], 1)[0]
    gravity_drift = acceleration + ROLLING_DECELERATION
    assert gravity_drift == pytest.approx(5 / 7 * G * slope, rel=0.03)
    direction = positions[-1] / np.linalg.norm(positions[-1])
    assert np.dot(direction, [math.cos(heading), math.sin(heading)]) > 0.999


@pytest.mark.parametrize("physics", PHYSICS)
@pytest.mark.parametrize("slope", [0.002, 0.005, 0.01])
def test_tilt_with_rolling_resistance_up_and_down_the_slope(slope, physics):
    """On the nominal ball the slope shows as the difference between uphill and downhill rolls."""
    sim = tilted_sim(0.0, slope, physics)
    decelerations = {}
    for name, vy, start in (("down", 1.5, -0.5), ("up", -1.5, 0.5)):
        launch(sim, (0.2, start), (0.0, vy))
        ts, speeds, _ = speed_history(sim, 2.0)
        decelerations[name] = fitted_deceleration(ts, speeds)
    drift = (decelerations["up"] - decelerations["down"]) / 2
    assert drift == pytest.approx(5 / 7 * G * slope, rel=0.03)
    assert (decelerations["up"] + decelerations["down"]) / 2 == pytest.approx(ROLLING_DECELERATION, rel=0.05)


@pytest.mark.parametrize("speed", [0.5, 1.0, 2.0, 3.5, 5.0])
@pytest.mark.parametrize(
    "start, direction, normal",
    [
        ((0.2, 0.1), (1, 0), (-1, 0)),  # side wall, +x
        ((-0.2, -0.3), (-1, 0), (1, 0)),  # side wall, -x
        ((0.22, 0.3), (0, 1), (0, -1)),  # end wall beside the away goal
        ((-0.22, -0.3), (0, -1), (0, 1)),  # end wall beside the home goal
    ],
)
def test_straight_wall_bounce_returns_the_nominal_restitution(table, speed, start, direction, normal):
    e = wall_bounce(table, start, speed * np.asarray(direction, dtype=float), normal)
    assert e == pytest.approx(WALL_RESTITUTION, abs=0.05)


@pytest.fixture(scope="module", params=PHYSICS)
def still_rods_table(request) -> TableSimulation:
    """The nominal table with rods too heavy to recoil: its figures stay at rest through a bounce."""
    params = copy.deepcopy(NOMINAL)
    params["rods"]["rotate_armature"] = 100.0
    params["rods"]["slide_armature"] = 1.0e5
    return TableSimulation(params=params, physics=request.param)


@pytest.mark.parametrize("speed", [0.5, 1.0, 2.0, 3.5, 5.0])
@pytest.mark.parametrize("rod, figure_x", [("home_midfield", 0.0), ("home_defence", 0.12), ("home_goalie", 0.0)])
def test_figure_bounce_returns_the_nominal_restitution(still_rods_table, speed, rod, figure_x):
    """Against a figure at rest (its rod held still), the ball comes back at the figures' restitution."""
    e = figure_bounce(still_rods_table, rod, speed, figure_x)
    assert e == pytest.approx(FIGURE_RESTITUTION, abs=0.05)


def _random_launches(physics: str, seed: int, count: int, seconds: float = 0.2) -> dict:
    """Worker: random launches up to 10 m/s with rods driven randomly; the worst of what happened.

    The reference is stepped by mj_step alone (its springs are the whole physics); the fast physics
    through the API one step at a time (its impacts are resolved between MuJoCo's collision and forces)."""
    sim = TableSimulation(physics=physics)
    model, data = sim.model, sim.data
    rng = np.random.default_rng(seed)
    worst_penetration, escapes, non_finite, goals = 0.0, [], 0, 0
    half_w, half_l, r = sim.half_width, sim.half_length, sim.ball_radius
    mouth = sim.goal_half_width
    pocket_back = half_l + sim.params["field"]["goal_depth"]
    cover = sim.params["field"]["cover_height"]
    tol = 0.002
    rotations = np.array([n.endswith("rotate") for n in JOINT_NAMES])
    ball_adr = model.jnt_qposadr[model.joint("ball").id]
    steps_per_command = round(0.02 / sim.timestep)  # new random rod velocities every 20 ms
    one_step = (lambda: mujoco.mj_step(model, data)) if physics == "reference" else (lambda: sim.advance(sim.timestep))
    for launch_index in range(count):
        for _ in range(100):
            speed, heading = rng.uniform(0.0, 10.0), rng.uniform(-math.pi, math.pi)
            rods = np.where(rotations, rng.uniform(-math.pi, math.pi, 16), rng.uniform(-0.08, 0.08, 16))
            sim.reset(
                (rng.uniform(-half_w + r, half_w - r), rng.uniform(-half_l + r, half_l - r)),
                (speed * math.cos(heading), speed * math.sin(heading)),
                joint_positions=rods,
            )
            if sim.ball_is_clear():
                break
        steps = int(seconds / sim.timestep)
        for step in range(steps):
            if step % steps_per_command == 0:
                for team in ("home", "away"):
                    sim.set_command(team, rng.uniform(-1, 1, 8) * sim.command_limits)
            one_step()
            if data.ncon:
                worst_penetration = max(worst_penetration, -float(data.contact.dist[: data.ncon].min()))
            x, y, z = data.qpos[ball_adr : ball_adr + 3]
            ax, ay = abs(x), abs(y)
            inside_field = ax <= half_w - r + tol and ay <= half_l - r + tol
            in_mouth = ay <= half_l + r + tol and ax <= mouth + tol
            in_pocket = ay <= pocket_back - r + tol and ax <= mouth - r + tol
            vertical_ok = r - tol <= z <= cover - r + tol
            if not ((inside_field or in_mouth or in_pocket) and vertical_ok):
                escapes.append((launch_index, step, float(x), float(y), float(z)))
                break
        if not np.all(np.isfinite(data.qpos)) or data.warning[mujoco.mjtWarning.mjWARN_BADQACC].number > 0:
            non_finite += 1
        goals += sim.goal() is not None
    return {"penetration": worst_penetration, "escapes": escapes, "non_finite": non_finite, "goals": goals}


@pytest.mark.timeout(600)
@pytest.mark.parametrize("physics", PHYSICS)
def test_thousand_random_launches_stay_in_the_table(physics):
    with ProcessPoolExecutor(max_workers=2) as pool:
        results = list(pool.map(_random_launches, [physics] * 4, [11, 12, 13, 14], [250] * 4))
    escapes = [e for r in results for e in r["escapes"]]
    assert not escapes, f"balls left the table outside a goal mouth: {escapes[:5]}"
    assert sum(r["non_finite"] for r in results) == 0
    worst = max(r["penetration"] for r in results)
    assert worst < 0.002, f"penetration {worst * 1000:.2f} mm"
    assert sum(r["goals"] for r in results) > 0, "some of 1000 random launches should score"


def full_speed_kick(sim: TableSimulation, drawn_back: float = -0.6, ball_offset: float = 0.025, rod: str = "attack"):
    """Peak planar speed of a resting ball kicked by a home figure swung at full speed from `drawn_back`
    rad, the ball `ball_offset` m ahead of the rod (on the centre figure's line); and where it went."""
    rotate = JOINT_NAMES.index(f"home_{rod}_rotate")
    rods = np.zeros(16)
    rods[rotate] = drawn_back  # foot drawn back
    y_rod = float(sim.params["rods"]["layout"][f"home_{rod}"]["y"])
    sim.reset((0.0, y_rod + ball_offset), (0.0, 0.0), joint_positions=rods)
    command = np.zeros(8)
    command[rotate % 8] = sim.command_limits[rotate % 8]  # rotate, full speed
    sim.set_command("home", command)
    peak = 0.0
    for _ in range(60):
        sim.advance(0.001)
        peak = max(peak, float(np.linalg.norm(sim.ball_velocity()[:2])))
    return peak, sim.ball_position()


@pytest.fixture(scope="module", params=PHYSICS)
def servo_table(request) -> TableSimulation:
    """The former 40 rad/s velocity servos (params/servo_table.yaml) on each physics."""
    return TableSimulation(SERVO_PARAMS_FILE, physics=request.param)


def test_full_speed_kick_on_the_former_servos_sends_a_resting_ball_off_at_their_shot_speed(servo_table):
    """The kicks of every result before the jerk-limited drives (tests/foos_sim/test_kicks.py has today's)."""
    peak, position = full_speed_kick(servo_table)
    assert 3.0 < peak < 4.5
    assert position[1] > 0.3, "kicked toward the away goal (+y)"


@pytest.mark.parametrize("vy, scorer", [(3.0, "home"), (-3.0, "away")])
def test_goals_through_the_mouth_and_not_through_the_wall(table, vy, scorer):
    launch(table, (0.0, 0.3 * np.sign(vy)), (0.0, vy))
    assert table.advance(0.5) == scorer
    launch(table, (0.2, 0.3 * np.sign(vy)), (0.0, vy))
    assert table.advance(0.5) is None
    assert abs(table.ball_position()[1]) < 0.6


def test_velocity_servos_follow_commands_and_respect_limits(table):
    table.reset()
    command = np.zeros(8)
    command[4] = 0.2  # midfield slide, m/s
    command[5] = 1000.0  # midfield rotate, beyond the limit
    applied = table.set_command("home", command)
    assert applied[5] == pytest.approx(table.command_limits[5])
    table.advance(0.25)  # past the jerk-limited drives' 0.19 s from rest to full speed
    velocities = table.joint_velocities()
    assert velocities[JOINT_NAMES.index("home_midfield_slide")] == pytest.approx(0.2, rel=0.02)
    assert velocities[JOINT_NAMES.index("home_midfield_rotate")] == pytest.approx(table.command_limits[5], rel=0.02)
    moving = {JOINT_NAMES.index("home_midfield_slide"), JOINT_NAMES.index("home_midfield_rotate")}
    others = [i for i in range(16) if i not in moving]
    assert np.max(np.abs(velocities[others])) < 1e-3
    assert np.all(np.abs(table.joint_efforts()) <= table.drive_servo().force_limit)
    table.advance(0.5)
    # The travel stop is a soft joint limit, like a rubber bumper: a rod driven into it at full force
    # compresses it by a few millimetres, never past the side wall.
    travel = table.model.joint("home_midfield_slide").range[1]
    assert table.joint_positions()[JOINT_NAMES.index("home_midfield_slide")] <= travel + 0.005


def test_a_drive_reaches_its_command_without_overshoot(table):
    """From rest to full rotation speed the drive rises (on its S-curve), then holds its command: no step
    overshoots it (at 2 ms MuJoCo's own clipping alternated 26 and 53 rad/s for a 40 rad/s command)."""
    table.reset()
    command = np.zeros(8)
    command[7] = table.command_limits[7]  # attack rotate
    table.set_command("home", command)
    rotate = JOINT_NAMES.index("home_attack_rotate")
    speeds = []
    for _ in range(int(0.25 / table.timestep)):
        table.advance(table.timestep)
        speeds.append(table.joint_velocities()[rotate])
    assert max(speeds) <= 1.01 * command[7]
    assert speeds[-1] == pytest.approx(command[7], rel=0.01)
    assert np.all(np.diff(speeds) >= -0.01 * command[7]), "the speed rises to the command and stays"


@pytest.mark.parametrize("team", ["home", "away"])
def test_figure_contacts_name_the_team_whose_figure_the_ball_touches(table, team):
    # Only `team`'s rods hang down; the ball rolls from the centre line into its attack figures.
    rods = np.array([0.0 if name.startswith(team) or not name.endswith("rotate") else np.pi / 2 for name in JOINT_NAMES])
    direction = 1.0 if team == "home" else -1.0
    launch(table, (0.0, 0.1 * direction), (0.0, 1.0 * direction), rods=rods)
    assert table.figure_contacts() == (False, False)
    seen = set()
    for _ in range(int(0.3 / 0.00025)):
        table.advance(0.00025)
        seen.add(table.figure_contacts())
    assert seen == {(False, False), (team == "home", team == "away")}
    touches = table.figure_touches()
    assert touches[0 if team == "home" else 1] >= 1 and touches[1 if team == "home" else 0] == 0
    assert abs(table.last_touch_ball_position(team)[1] - 0.225 * direction) < 0.05


def test_a_diverged_state_is_not_finite(nominal_sim):
    nominal_sim.reset()
    assert nominal_sim.state_is_finite()
    nominal_sim.data.qpos[0] = np.nan
    assert not nominal_sim.state_is_finite()
    nominal_sim.reset()
