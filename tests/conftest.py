"""Fixtures shared by the simulator tests: the hand-made tools and a hammering world built once."""

import pytest

from tognet.objects.handmade import make_test_tools
from tognet.sim import SimConfig, Simulator


@pytest.fixture(scope="session")
def tools(tmp_path_factory):
    """The hand-made T hammer and L tool (read-only object records)."""
    return make_test_tools(tmp_path_factory.mktemp("tools"))


@pytest.fixture(scope="module")
def hammer_sim(tools):
    """A hammering world with the T hammer, one per test module (tests reset it as they need)."""
    return Simulator(SimConfig(), "hammering", tools["t_hammer"])
