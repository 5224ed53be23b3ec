"""Recording test fixtures; puts this folder on sys.path for ``recording_helpers``."""

import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).parent))

from recording_helpers import write_trial  # noqa: E402


@pytest.fixture
def trial_mcap(tmp_path):
    return write_trial(tmp_path / "trial.mcap", missing={"cam1": {5, 6}})
