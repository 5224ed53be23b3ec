"""Several people in view, end to end in the worker: a real MCAP of a patient with a therapist beside,
association, the automatic (or the clinician's) choice, and the reconstruction against ground truth."""

import json
from dataclasses import replace

import numpy as np
import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.people import PatientChoice, most_people_in_view, write_choice
from gaitcap.services.processing.worker import Worker, WorkerConfig

from ..conftest import write_multi_trial_mcap


@pytest.fixture(scope="module")
def pair():
    from gaitcap.simulator import make_trial

    return make_trial(preset="paper", seconds=6.0, cameras=6, people=2, seed=1)


def _mpjpe(points_mm, truth_mm) -> float:
    return float(np.nanmean(np.linalg.norm(points_mm - truth_mm, axis=-1)))


def _alone(trial, person: int) -> np.ndarray:
    """Robust triangulation of one person's detections alone (no one else in view), (T, J, 3) mm."""
    from gaitcap.reconstruction.keypoints import MultiViewKeypoints
    from gaitcap.reconstruction.triangulation import robust_triangulate

    det = MultiViewKeypoints.of_one_person(trial.multi.person(person), trial.rig.names, trial.times_s, trial.skeleton)
    return np.asarray(robust_triangulate(det, trial.rig).points_mm)


def _recorded(tmp_path, trial):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1",
                        recording_path_for=lambda tid: trial_files(tmp_path, tid).recording)
    write_multi_trial_mcap(trial, trial_files(tmp_path, t.id).recording)
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    return db, t.id


def _processed(db, tmp_path, tid):
    w = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False, lease_s=5), db=db)
    assert w.run_once()
    trial = cat.get_trial(db, tid)
    assert trial.state == "done", trial.error
    files = trial_files(tmp_path, tid)
    with np.load(files.stage_file("preliminary", "trajectory_npz")) as data:
        return json.loads(files.people_json.read_text()), data["points_mm"]


def test_the_patient_is_found_and_reconstructed_not_the_therapist(tmp_path, pair):
    db, tid = _recorded(tmp_path, pair)
    people, points = _processed(db, tmp_path, tid)
    assert people["chosen_by"] == "automatic" and len(people["people"]) == 2
    assert people["patient_track_id"] in [p["track_id"] for p in people["people"]]
    assert all(p["seen_s"] > 5.0 for p in people["people"])
    marked = {m["track_id"] for boxes in people["boxes_px"].values() for m in boxes}
    assert marked == {0, 1} and set(people["image_sizes_px"]) == set(people["cameras"])
    alone = _alone(pair, 0)
    patient, therapist = pair.all_points_mm[0], pair.all_points_mm[1]
    assert _mpjpe(points, patient) <= 1.10 * _mpjpe(alone, patient) + 1.0
    assert _mpjpe(points, therapist) > 300.0


def test_the_clinicians_choice_wins(tmp_path, pair):
    db, tid = _recorded(tmp_path, pair)
    files = trial_files(tmp_path, tid)
    auto, _ = _processed(db, tmp_path, tid)
    other = next(p["track_id"] for p in auto["people"] if p["track_id"] != auto["patient_track_id"])
    write_choice(files, PatientChoice(track_id=other, chosen_by="alice", how="list"))
    cat.set_state(db, tid, "recorded")
    cat.enqueue_job(db, tid)
    people, points = _processed(db, tmp_path, tid)
    assert people["patient_track_id"] == other and people["chosen_by"] == "clinician"
    therapist = _alone(pair, 1)
    assert _mpjpe(points, pair.all_points_mm[1]) <= 1.10 * _mpjpe(therapist, pair.all_points_mm[1]) + 1.0
    assert _mpjpe(points, pair.all_points_mm[0]) > 300.0


def test_a_choice_of_a_track_that_does_not_exist_fails_the_trial_with_the_reason(tmp_path, pair):
    db, tid = _recorded(tmp_path, pair)
    write_choice(trial_files(tmp_path, tid), PatientChoice(track_id=7, chosen_by="alice"))
    Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    trial = cat.get_trial(db, tid)
    assert trial.state == "failed" and "track 7" in trial.error and "alice" in trial.error


def test_people_in_view_and_choice_validation(pair):
    assert most_people_in_view(pair.multi.observed) == 2
    assert most_people_in_view(replace(pair.multi.observed, keypoints=pair.detections.keypoints)) == 1
    assert most_people_in_view(replace(pair.multi.observed, keypoints=pair.multi.observed.keypoints[:, :, :0])) == 0
    with pytest.raises(ValueError, match="track_id"):
        PatientChoice(track_id=-1)


def _agreement(keypoints, person_kp) -> float:
    """Fraction of the person's detected joints found at the same pixel (the MCAP keeps 0.01 px)."""
    seen = np.isfinite(person_kp[..., 0]) & (person_kp[..., 2] > 0)
    same = np.abs(np.nan_to_num(keypoints[..., 0], nan=-1e9) - person_kp[..., 0]) < 0.02
    return float((same & seen).sum() / seen.sum())


def test_patient_of_honours_a_choice_and_writes_nothing(tmp_path, pair):
    from gaitcap.acquisition.recording.reader import read_keypoints
    from gaitcap.services.processing.people import patient_of, select_patient

    path = write_multi_trial_mcap(pair, tmp_path / "t" / "recording.mcap")
    rec = read_keypoints(path)
    assert _agreement(patient_of(rec, pair.rig).one_person, pair.multi.person(0)) > 0.95
    other = 1 - select_patient(rec, pair.rig, None).track_id
    assert _agreement(patient_of(rec, pair.rig, PatientChoice(other)).one_person, pair.multi.person(1)) > 0.95
    assert sorted(p.name for p in path.parent.iterdir() if p.suffix != ".toml") == ["recording.mcap"]
