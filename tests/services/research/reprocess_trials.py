"""Recorded synthetic trials in a catalog, as the recorder and worker leave them (for the reprocess,
sweep and Ray tests): ``<data_dir>/trials/<id>/recording.mcap`` plus the world's ``ground_truth.npz``."""

import shutil
import tempfile
from pathlib import Path

from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files

from ..conftest import write_trial_mcap


def make_walks(n: int, *, seconds: float = 9.0, cameras: int = 6, preset: str = "paper"):
    from gaitcap.simulator import make_trial

    return [make_trial(preset, seconds=seconds, cameras=cameras, people=1, seed=10 + i, fps=30) for i in range(n)]


def recorded_catalog(data_dir: Path, walks, *, subject: str = "P1") -> tuple[cat.Catalog, list[str]]:
    """A catalog with one recorded (state ``done``) trial per walk; returns it and the trial ids."""
    from gaitcap.simulator import save_trial

    db = cat.open_catalog(data_dir / "catalog.sqlite")
    ids = []
    for i, walk in enumerate(walks):
        t = cat.start_trial(db, subject_id=subject, session="s1", trial_id=f"trial-{i:02d}",
                            recording_path_for=lambda tid: trial_files(data_dir, tid).recording)
        files = trial_files(data_dir, t.id)
        write_trial_mcap(walk, files.recording)
        with tempfile.TemporaryDirectory() as tmp:
            save_trial(walk, tmp)
            shutil.copy(Path(tmp) / "ground_truth.npz", files.root / "ground_truth.npz")
        cat.set_state(db, t.id, "recorded")
        ids.append(t.id)
    return db, ids
