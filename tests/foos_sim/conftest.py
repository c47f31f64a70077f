"""Fixtures of the foos_sim tests."""
import pytest

from foos_sim.model_builder import PHYSICS
from foos_sim.simulation import TableSimulation


@pytest.fixture(scope="session")
def nominal_sim() -> TableSimulation:
    """The nominal table on the physics its parameter file names (the fast one)."""
    return TableSimulation()


@pytest.fixture(scope="session", params=PHYSICS)
def table(request) -> TableSimulation:
    """The nominal table on each physics: every acceptance test holds on both."""
    return TableSimulation(physics=request.param)
