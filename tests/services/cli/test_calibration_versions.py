"""Calibration versions end to end on a real catalog and real trial MCAPs: two synthetic trials recorded
under a stale calibration (one camera turned 2 deg after it was made), the worker flags the camera;
``gaitcap refine-rig --data-dir`` stores a refined version replacing it, with its comparison; ``gaitcap
apply-calibration --run`` reprocesses both trials under it through the worker, and the camera is no
longer flagged."""

from __future__ import annotations

from dataclasses import replace

import pytest
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg
from gaitcap.reconstruction.calibration_io import rig_from_toml_text, rig_to_toml_text
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.methods import Robust
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import calibration_versions as versions
from gaitcap.services.catalog import method_results as store
from gaitcap.services.catalog.method_keys import params_key
from gaitcap.services.cli import app
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.worker import Worker, WorkerConfig
from gaitcap.simulator.rig_faults import with_camera_moved
from typer.testing import CliRunner

from ..conftest import write_trial_mcap

MOVED = "cam02"


def _stale(rig: Rig) -> Rig:
    """The rig as calibrated before ``MOVED`` was turned 2 deg (its calibration is now 2 deg off)."""
    return with_camera_moved(rig, MOVED, rotation_deg=2.0)


def _rig_check(db, trial_id: str) -> dict:
    return cat.get_quality(db, trial_id)["processing"]["checks"]["rig"]


@pytest.fixture(scope="module")
def clinic(tmp_path_factory):
    from gaitcap.simulator import make_trial

    tmp = tmp_path_factory.mktemp("clinic")
    db = cat.open_catalog(tmp / "catalog.sqlite")
    walk = make_trial("clean", seconds=8, cameras=5, people=1, seed=4, fps=30)  # the rig depends on the seed
    stale = _stale(walk.rig)
    old = cat.add_calibration(db, toml=rig_to_toml_text(stale), source="board, before the bump")
    trials = []
    for _ in range(2):  # two trials recorded under the stale calibration (the same walk twice)
        t = cat.start_trial(db, subject_id="P1", session="s1", calibration_id=old,
                            recording_path_for=lambda tid: tmp / "rec" / f"{tid}.mcap")
        write_trial_mcap(replace(walk, rig=stale), t.recording_path)  # the recording carries the stale one
        cat.set_state(db, t.id, "recorded", enqueue=True)
        trials.append(t.id)
    worker = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp, refine=False, lease_s=5), db=db)
    while worker.run_once():
        pass
    return db, tmp, old, trials, walk.rig


def test_a_refined_version_replaces_the_stale_one_and_the_trials_are_reprocessed_under_it(clinic):
    db, tmp, old, trials, truth = clinic
    assert [_rig_check(db, t)["moved"] for t in trials] == [[MOVED], [MOVED]]
    assert [_rig_check(db, t)["baseline_trial"] for t in trials] == [None, None]  # a flagged trial is no baseline
    recorded = params_key(Robust())  # processed from the recording alone: the key research computes
    assert [store.get_result(db, t, "robust", recorded).stage for t in trials] == ["preliminary"] * 2
    assert versions.trials_using(db, old) == trials
    runner = CliRunner()
    res = runner.invoke(app, ["refine-rig", trials[0], "--data-dir", str(tmp), "--max-frames", "60"])
    assert res.exit_code == 0, res.output
    new = cat.latest_calibration(db)[0]
    assert new != old and f"stored calibration {new} replacing {old}" in res.output
    version = versions.get_version(db, new)
    assert version.replaces_id == old and version.made_by == "refine-rig" and version.trials == (trials[0],)
    assert version.comparison[MOVED]["rotation_deg"] > 1.5  # the report compares it with the one it replaces
    assert all(v["rotation_deg"] < 0.3 for n, v in version.comparison.items() if n != MOVED), version.comparison
    assert versions.lineage(db, new) == [new, old] and versions.get_version(db, old) is None
    refined = rig_from_toml_text(cat.calibration_toml(db, new))
    assert rotation_angle_deg(refined[MOVED].rotation, truth[MOVED].rotation) < 0.3
    assert cat.get_calibration(db, old).state == "done"  # every version is kept

    res = runner.invoke(app, ["apply-calibration", new, "--data-dir", str(tmp), "--run", "--no-refine"])
    assert res.exit_code == 0, res.output
    assert f"2 trial(s) queued for processing again: {trials[0]}, {trials[1]}" in res.output
    assert versions.trials_using(db, new) == trials and versions.trials_using(db, old) == []
    for t in trials:
        assert cat.get_trial(db, t).state in ("done", "done_with_warnings")
        assert _rig_check(db, t)["moved"] == [], _rig_check(db, t)  # processed with the refined version
    # the first trial under the new version whose check found nothing moved is the later ones' baseline
    assert [_rig_check(db, t)["baseline_trial"] for t in trials] == [None, trials[0]]
    assert {c["baseline"] for c in _rig_check(db, trials[1])["cameras"].values()} <= {"compared", "no field there", "not judged there"}
    assert trial_files(tmp, trials[0]).rig_keypoints_npz.is_file()
    assert versions.get_version(db, new).applied_at is not None
    under_new = params_key(Robust(), inputs={"calibration": new})  # never the key of the recording alone
    for t in trials:
        assert store.get_result(db, t, "robust", recorded) is None
        assert store.get_result(db, t, "robust", under_new).stage == "preliminary"
    again = runner.invoke(app, ["apply-calibration", new, "--data-dir", str(tmp)])
    assert again.exit_code == 0 and "0 trial(s) queued" in again.output  # none uses the old one any more


def test_bad_arguments_are_named(clinic, tmp_path):
    db, tmp, old, trials, _ = clinic
    runner = CliRunner()
    res = runner.invoke(app, ["apply-calibration", old, "--data-dir", str(tmp)])
    assert res.exit_code != 0 and f"calibration {old} replaces no other calibration" in res.output
    res = runner.invoke(app, ["refine-rig", "T-nope", "--data-dir", str(tmp)])
    assert res.exit_code != 0 and "T-nope: neither a file or folder nor a trial in the catalog" in res.output
    res = runner.invoke(app, ["apply-calibration", old, "--data-dir", str(tmp_path)])
    assert res.exit_code != 0 and "catalog.sqlite does not exist" in res.output
    with pytest.raises(cat.CalibrationNotFound, match="C-nope not found"):
        versions.add_version(db, toml="[x]", replaces_id="C-nope", made_by="t", trials=[], comparison={})
