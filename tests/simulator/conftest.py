"""Shared short synthetic trials (cached per session: the tests only read them)."""

import pytest
from gaitcap.simulator import make_trial


@pytest.fixture(scope="session")
def clean_trial():
    return make_trial(preset="clean", seconds=12.0, cameras=10, seed=3)


@pytest.fixture(scope="session")
def paper_trial():
    return make_trial(preset="paper", seconds=12.0, cameras=10, seed=3)


@pytest.fixture(scope="session")
def multi_trial():
    return make_trial(preset="paper", seconds=8.0, cameras=6, people=3, seed=5)

