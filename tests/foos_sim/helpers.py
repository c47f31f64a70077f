"""Shared helpers of the foos_sim tests."""
import numpy as np

from foos_core.names import JOINT_NAMES, TEAMS
from foos_sim.simulation import TableSimulation

# Rotations at pi/2 lay every figure horizontal at rod height, clear of a rolling ball.
RODS_UP = np.array([np.pi / 2 if name.endswith("rotate") else 0.0 for name in JOINT_NAMES])


def launch(sim: TableSimulation, position, velocity, rods=RODS_UP, rolling=True) -> None:
    sim.reset(ball_position=position, ball_velocity=velocity, joint_positions=rods, rolling=rolling)


def rods_up_but(*rods: str) -> np.ndarray:
    """Every figure laid flat except those of the named rods (e.g. "home_midfield"), which hang down."""
    joints = RODS_UP.copy()
    for rod in rods:
        joints[JOINT_NAMES.index(f"{rod}_rotate")] = 0.0
    return joints


def sample_period(sim: TableSimulation) -> float:
    """s between samples of a ball's motion: 1 ms, or one step where steps are longer."""
    return max(sim.timestep, 0.001)


def wall_bounce(sim: TableSimulation, start, velocity, wall_normal) -> float:
    """Normal speed out / in of one wall bounce, sampled every step; wall_normal points into the field.

    Geometric, so it reads both physics alike: the speed in is the last one while approaching clear of
    the wall, the speed out the first one while leaving clear of it (the reference's springs overlap the
    wall for about 0.5 ms; the fast physics' impulse leaves no overlap)."""
    launch(sim, start, velocity)
    n = np.asarray(wall_normal, dtype=float)
    inner = np.array([sim.half_width, sim.half_length]) - sim.ball_radius
    v_in = None
    for _ in range(int(1.0 / sim.timestep)):
        sim.advance(sim.timestep)
        clear = bool(np.all(np.abs(sim.ball_position()[:2]) <= inner))
        v_n = float(np.dot(sim.ball_velocity()[:2], n))
        if clear and v_n < 0:
            v_in = v_n
        elif clear and v_n > 0 and v_in is not None:
            return -v_n / v_in
    raise AssertionError("the ball never left the wall")


def figure_bounce(sim: TableSimulation, rod: str, speed: float, figure_x: float = 0.0) -> float:
    """The ball's speed out / in after rolling at `speed` (+y) into a figure at rest of `rod` (hanging;
    every other figure laid flat), sampled every step: the speed in is the last before the ball touches
    the figure, the speed out the first after it has stopped touching."""
    y_rod = float(sim.params["rods"]["layout"][rod]["y"])
    team = TEAMS.index(rod.split("_", 1)[0])
    launch(sim, (figure_x, y_rod - 0.055), (0.0, speed), rods=rods_up_but(rod))
    v_in, touched = None, False
    for _ in range(int(0.3 / sim.timestep)):
        v_before = float(sim.ball_velocity()[1])
        sim.advance(sim.timestep)
        if sim.figure_contacts()[team]:
            if not touched:
                v_in, touched = v_before, True
        elif touched:
            return -float(sim.ball_velocity()[1]) / v_in
    raise AssertionError("the ball never left the figure")
