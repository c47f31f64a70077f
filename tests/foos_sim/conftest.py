"""Fixtures of the foos_sim tests."""
import pytest

from foos_sim.simulation import TableSimulation


@pytest.fixture(scope="session")
def nominal_sim() -> TableSimulation:
    return TableSimulation()
