"""Shared helpers of the foos_sim tests."""
import numpy as np

from foos_core.names import JOINT_NAMES
from foos_sim.simulation import TableSimulation

# Rotations at pi/2 lay every figure horizontal at rod height, clear of a rolling ball.
RODS_UP = np.array([np.pi / 2 if name.endswith("rotate") else 0.0 for name in JOINT_NAMES])


def launch(sim: TableSimulation, position, velocity, rods=RODS_UP, rolling=True) -> None:
    sim.reset(ball_position=position, ball_velocity=velocity, joint_positions=rods, rolling=rolling)
