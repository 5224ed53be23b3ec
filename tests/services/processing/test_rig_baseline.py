"""The clinic's rig check against a baseline: the first trial under a calibration whose own check found no
camera moved keeps the patient's keypoints it judged, and later trials under that calibration are judged by
the change since it (real catalog, real files; the synthetic clinic for the keypoints)."""

from __future__ import annotations

import numpy as np
import pytest
from gaitcap.reconstruction.calibration.rig_check import checked_frames
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.rig_checks import baseline_trial_ids
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.checks import CheckContext, rig_check
from gaitcap.services.processing.trial import write_rig_keypoints
from gaitcap.services.processing.worker import rig_baseline
from gaitcap.simulator import make_trial
from gaitcap.simulator.rig_faults import with_camera_moved

MOVED = "cam02"


@pytest.fixture(scope="module")
def walk():
    return make_trial("clean", seconds=16, cameras=5, people=1, seed=4, fps=30)


def _halves(det):
    mid = det.shape[1] // 2
    return det.frames(slice(None, mid)), det.frames(slice(mid, None))


def _finished(db, calibration_id: str, check: dict | None) -> str:
    t = cat.start_trial(db, subject_id="P7", session="s1", calibration_id=calibration_id,
                        recording_path_for=lambda tid: f"/nowhere/{tid}.mcap")
    for state in ("recorded", "processing", "done"):
        cat.set_state(db, t.id, state)
    cat.set_quality(db, t.id, "processing", {"checks": {"rig": check}} if check is not None else {})
    return t.id


def test_the_first_unflagged_trial_under_the_calibration_is_the_baseline(tmp_path, walk):
    db = cat.open_catalog(f"sqlite:///{tmp_path / 'catalog.db'}")
    cal = cat.add_calibration(db, toml=rig_to_toml_text(walk.rig))
    other = cat.add_calibration(db, toml=rig_to_toml_text(walk.rig))
    flagged = _finished(db, cal, {"run": True, "flagged": True})
    not_run = _finished(db, cal, {"run": False, "flagged": False})
    _finished(db, other, {"run": True, "flagged": False})
    first = _finished(db, cal, {"run": True, "flagged": False})
    second = _finished(db, cal, {"run": True, "flagged": False})
    current = cat.start_trial(db, subject_id="P8", session="s2", calibration_id=cal).id
    assert baseline_trial_ids(db, cal, excluding=current) == [first, second], (flagged, not_run)
    assert baseline_trial_ids(db, cal, excluding=first) == [second]  # a trial is never its own baseline
    assert baseline_trial_ids(db, None, excluding=current) == []

    det = walk.detections
    write_rig_keypoints(trial_files(tmp_path, first), det)
    context = rig_baseline(db, tmp_path, cat.get_trial(db, current))
    assert context.baseline_trial == first
    kept = context.rig_baseline
    frames = checked_frames(det.shape[1])  # the frames the check judges (every other one of 480)
    assert kept.camera_names == det.camera_names and kept.shape[1] == len(frames) < det.shape[1]
    np.testing.assert_allclose(kept.one_person, det.one_person[:, frames])

    trial_files(tmp_path, first).rig_keypoints_npz.write_bytes(b"not a keypoint file")
    assert rig_baseline(db, tmp_path, cat.get_trial(db, current)).rig_baseline is None  # none readable: without
    write_rig_keypoints(trial_files(tmp_path, second), det)  # the next candidate with a readable file is taken
    assert rig_baseline(db, tmp_path, cat.get_trial(db, current)).baseline_trial == second


def test_a_camera_turned_since_the_baseline_trial_is_named_with_the_turn_since(walk):
    before, after = _halves(walk.detections)
    stale = with_camera_moved(walk.rig, MOVED, rotation_deg=2.0)  # the camera turned; the calibration did not
    from gaitcap.simulator.rig_faults import seen_from

    baseline = seen_from(before, walk.rig, stale, MOVED)  # recorded before it turned
    context = CheckContext(rig_baseline=baseline, baseline_trial="T-first")
    check = rig_check(after, stale, robust_triangulate(after, stale).points_mm, context)
    assert check["moved"] == [MOVED] and check["baseline_trial"] == "T-first"
    assert check["cameras"][MOVED]["baseline"] in ("compared", "no field there")  # judged, with it at hand
    assert {c["baseline"] for c in check["cameras"].values()} <= {"compared", "no field there", "not judged there"}
    assert any("since trial T-first" in n for n in check["notes"])
    assert abs(check["cameras"][MOVED]["rotation_deg"] - 2.0) < 0.3


def test_a_baseline_of_other_cameras_is_set_aside_and_said(walk):
    det = walk.detections
    fewer = type(det).of_one_person(det.one_person[:3], det.camera_names[:3], det.times_s, det.skeleton)
    context = CheckContext(rig_baseline=fewer, baseline_trial="T-old")
    check = rig_check(det, walk.rig, robust_triangulate(det, walk.rig).points_mm, context)
    assert check["run"] and check["baseline_trial"] is None and not check["flagged"]
    assert any("T-old was set aside" in n and "lacks camera" in n for n in check["notes"]), check["notes"]
    assert {c["baseline"] for c in check["cameras"].values()} == {"none"}


def test_the_page_summary_names_the_baseline_trial(tmp_path, walk):
    """``GET /rig-check/latest`` reads the latest check with the trial it was judged against."""
    from gaitcap.services.catalog.rig_checks import latest_rig_check

    db = cat.open_catalog(f"sqlite:///{tmp_path / 'catalog.db'}")
    cal = cat.add_calibration(db, toml=rig_to_toml_text(walk.rig))
    before, after = _halves(walk.detections)
    check = rig_check(after, walk.rig, robust_triangulate(after, walk.rig).points_mm,
                      CheckContext(rig_baseline=before, baseline_trial="T-first"))
    latest = _finished(db, cal, check)
    got = latest_rig_check(db)
    assert got["trial_id"] == latest and got["baseline_trial"] == "T-first" and not got["flagged"]
    assert all("rotation_bound_deg" in c and "shift_bound_mm" in c for c in got["cameras"])
