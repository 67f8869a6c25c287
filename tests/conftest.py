import os
from pathlib import Path

import numpy as np
import pytest
from _background import BackgroundRun

os.environ.setdefault("MPLBACKEND", "Agg")

SHARED_DATA = Path(__file__).resolve().parents[2] / "shared" / "data"


@pytest.fixture
def rng():
    return np.random.default_rng(0)


@pytest.fixture(scope="session")
def shared_data():
    if not SHARED_DATA.is_dir():
        pytest.skip(f"shared data folder {SHARED_DATA} is absent")
    return SHARED_DATA


def pytest_configure(config):
    config.addinivalue_line("markers", "background_run: the test waits for a background run; it runs last")


def pytest_collection_modifyitems(items):
    """Tests that wait for a background run go last, which leaves the run the session to finish."""
    items.sort(key=lambda item: item.get_closest_marker("background_run") is not None)


def pytest_collection_finish(session):
    """Start the background runs of the modules of the selected tests that wait for one
    (see ``_background.py``)."""
    waiting = [item for item in session.items if item.get_closest_marker("background_run") is not None]
    for module in dict.fromkeys(item.module for item in waiting):
        for run in module.BACKGROUND:
            run.start()


def pytest_sessionfinish(session):
    for run in BackgroundRun.every:
        run.close()
