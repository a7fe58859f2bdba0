"""Shared pytest options: seeded property tests take their seed and count from the
command line (`pytest --prop-seed 7 --prop-count 100000`) or the environment
(NAVKIT_PROP_SEED, NAVKIT_PROP_COUNT)."""

import os

import pytest


def pytest_addoption(parser):
    parser.addoption("--prop-seed", type=int, default=int(os.environ.get("NAVKIT_PROP_SEED", "1")),
                     help="seed of the seeded property tests")
    parser.addoption("--prop-count", type=int, default=int(os.environ.get("NAVKIT_PROP_COUNT", "300")),
                     help="cases per property test")


@pytest.fixture
def prop_seed(request) -> int:
    """Seed for property tests (printed on failure by the tests that use it)."""
    return request.config.getoption("--prop-seed")


@pytest.fixture
def prop_count(request) -> int:
    """Number of random cases per property test."""
    return request.config.getoption("--prop-count")
