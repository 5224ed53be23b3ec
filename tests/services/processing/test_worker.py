"""The worker on a real catalog and a real trial MCAP of a synthetic walk: results against ground truth."""

import json
import time
from pathlib import Path

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.report import curves_csv
from gaitcap.reconstruction.methods import Implicit, Robust
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import method_results as store
from gaitcap.services.catalog.method_keys import params_key
from gaitcap.services.catalog.patients import update_patient
from gaitcap.services.kinematics import availability
from gaitcap.services.kinematics.files import norms_for_age
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.processing.worker import Worker, WorkerConfig
from mcap.reader import make_reader

from ..conftest import write_trial_mcap

COMPLETED = {"keypoints": "completed after Stop"}  # what the worker folds into the key of such a result


@pytest.fixture(scope="module")
def walk():
    from gaitcap.simulator import make_trial

    return make_trial("clean", seconds=10, cameras=4, people=1, seed=3, fps=30)


def _recorded_trial(tmp_path, walk):
    """A recorded trial whose MCAP lies outside the worker's data folder: the worker opens it where the
    catalog says (the one source of truth of a trial's files)."""
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / "moved" / f"{tid}.mcap")
    write_trial_mcap(walk, Path(t.recording_path))
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    return db, t.id


def _step_length_errors(result, truth) -> list[float]:
    """Each measured step against the true step of the same foot at that heel strike (mm).

    Every measured step must be a real one: a step with no true heel strike of that foot within 0.1 s is
    a bogus step and fails the test."""
    errors = []
    for step in result.steps:
        same = np.flatnonzero((truth.foot == step["side"]) & (np.abs(truth.heel_strike_s - step["time_s"]) < 0.1))
        assert same.size == 1, f"measured step without a true heel strike: {step}"
        errors.append(step["step_length_mm"] - truth.step_length_mm[same[0]])
    return errors


def test_worker_stores_preliminary_then_refined_results_close_to_truth(tmp_path, walk):
    db, tid = _recorded_trial(tmp_path, walk)
    update_patient(db, "P1", birth_year=time.gmtime().tm_year - 40)  # the files carry the adults' band
    w = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=True, lease_s=5), db=db)
    assert w.run_once() and not w.run_once()
    trial = cat.get_trial(db, tid)
    assert trial.state == "done" and trial.progress == 1.0
    files = trial_files(tmp_path, tid)
    for stage, method in (("preliminary", "robust triangulation"), ("refined", "implicit trajectory fit")):
        r = cat.get_result(db, tid, stage)
        assert r.method == method
        errors = _step_length_errors(r, walk.truth.steps)
        # clean detections: both stages recover every step length to a few mm (measured: <= 1.2 mm)
        assert len(errors) >= 6 and np.abs(errors).max() < 3.0, (stage, errors)
        for key in ("trajectory_npz", "trajectory_trc", "gait_json", "steps_csv", "summary_csv", "report_png"):
            assert files.stage_file(stage, key).stat().st_size > 100, (stage, key)
        gait = json.loads(files.stage_file(stage, "gait_json").read_text())  # numbers with their quality
        assert gait["data_quality"]["cameras"] and "warnings" in gait["data_quality"], gait.get("data_quality")
        assert "one_person" not in gait["data_quality"]["checks"]  # the checks never hold a result back
        assert gait["consistency"]["ok"] and gait["consistency"]["comparisons"] > 0, gait["consistency"]
    assert files.stage_file("refined", "rerun_rrd").stat().st_size > 1000
    listed = cat.get_result(db, tid, "refined").artifacts  # each file listed once written
    assert {"rerun_rrd", "results_mcap", "trajectory_trc", "report_png"} <= set(listed)
    assert all(Path(p).is_file() for p in listed.values())
    with open(files.stage_file("refined", "results_mcap"), "rb") as f:  # the viewer files of the final stage
        summary = make_reader(f).get_summary()
    counts = {c.topic: summary.statistics.channel_message_counts[i] for i, c in summary.channels.items()}
    with np.load(files.stage_file("refined", "trajectory_npz")) as npz:
        assert counts["/skeleton"] == npz["times_s"].size
    assert counts["/gait/steps"] == len(cat.get_result(db, tid, "refined").steps)
    kin = json.loads(files.stage_file("refined", "kinematics_json").read_text())  # the step after the result
    assert kin["available"] is availability()[0], kin
    if kin["available"]:
        assert kin["curves"]["knee_flexion"]["left"]["n_cycles"] >= 1
        assert kin["norms"] == norms_for_age(40).to_dict() != norms_for_age(None).to_dict()  # as the page shows
        kin_dir = files.stage_file("refined", "kinematics_json").parent
        assert (kin_dir / "kinematics.csv").read_text() == curves_csv(kin)
    assert cat.get_result(db, tid, "refined").quality["GC_10"] > 0.9
    checks = json.loads(files.checks_json.read_text())  # once every stage is stored: one person, no camera moved
    assert not checks["one_person"]["mixed"] and checks["rig"]["run"] and not checks["rig"]["moved"], checks
    assert cat.get_quality(db, tid)["processing"]["checks"] == checks
    assert trial.stage == "done"  # the progress the page shows, from the trial's record
    assert cat.jobs_for_trial(db, tid)[0].state == "done"


def test_a_bad_recording_fails_the_trial_with_the_reason(tmp_path, walk):
    db, tid = _recorded_trial(tmp_path, walk)
    bad = Path(cat.get_trial(db, tid).recording_path)
    bad.write_bytes(b"not an mcap file")
    w = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db)
    assert w.run_once()
    trial = cat.get_trial(db, tid)
    assert trial.state == "failed" and trial.error.startswith(f"{bad}: not an MCAP file"), trial.error
    assert cat.jobs_for_trial(db, tid)[0].state == "failed"



def test_a_missing_recording_fails_the_trial_naming_it_and_the_path(tmp_path):
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    cat.set_state(db, t.id, "recorded", enqueue=True)
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    trial = cat.get_trial(db, t.id)
    assert trial.state == "failed" and trial.error == f"trial {t.id}: its recording {tmp_path / t.id}.mcap does not exist"


class _Killed(BaseException):
    """The worker process dying (not an error it handles)."""


def test_viewer_files_are_listed_in_the_catalog_only_once_written(tmp_path, walk, monkeypatch):
    """The .rrd fails half-way (a full disk: logged, the trial stays processed), then the worker dies while
    writing the results MCAP: the catalog lists neither, and every file it lists is there, whole."""
    from gaitcap.services.processing.viewers import files, rerun_trial, results_mcap

    def disk_full(*_a, **_k):
        raise OSError(28, "No space left on device")

    def killed(*_a, **_k):
        raise _Killed()

    # the .rrd's writer runs here, not in its child process, so that the failure patched in below reaches it
    monkeypatch.setattr(files, "write_rrd_apart", rerun_trial.write_trial_rrd)
    monkeypatch.setattr(rerun_trial, "_log_rig", disk_full)  # after the .rrd's temporary file is open
    monkeypatch.setattr(results_mcap, "_write_gait", killed)  # after the skeleton messages are written
    db, tid = _recorded_trial(tmp_path, walk)
    with pytest.raises(_Killed):
        Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    listed = cat.get_result(db, tid, "preliminary").artifacts
    assert set(listed) == {"trajectory_npz", "gait_json", "steps_csv", "summary_csv", "trajectory_trc", "report_png"}
    assert all(Path(p).stat().st_size > 100 for p in listed.values())
    folder = trial_files(tmp_path, tid).stage_file("preliminary", "rerun_rrd").parent
    assert not [p.name for p in folder.iterdir() if p.name.startswith(".") or p.suffix in (".rrd", ".mcap")]


def _processed_with(tmp_path, walk, monkeypatch, messages: list[tuple[str, bytes, int]]):
    """A synthetic walk's recording with extra keypoint ``messages`` (camera, payload, frame id) written
    before it is finished, processed by a real worker: (the trial's state, its processing quality, whether
    the preliminary result has steps)."""
    from gaitcap.acquisition.recording.writer import TrialWriter
    from gaitcap.simulator.recording import write_keypoint_recording

    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    original = TrialWriter.finish

    def with_messages(writer, summary):
        for cam, payload, fid in messages:
            writer.add_keypoints(cam, payload, timestamp_ns=1, frame_id=fid)
        return original(writer, summary)

    monkeypatch.setattr(TrialWriter, "finish", with_messages)
    write_keypoint_recording(walk, Path(t.recording_path))
    monkeypatch.undo()
    cat.set_state(db, t.id, "recorded", enqueue=True)
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    return cat.get_trial(db, t.id).state, cat.get_quality(db, t.id)["processing"], bool(
        cat.get_result(db, t.id, "preliminary").steps)


def test_a_stray_keypoint_frame_id_is_ignored_and_named_in_the_trials_quality(tmp_path, walk, monkeypatch):
    """A recording holding one keypoint message with a frame id of 2**40 (a corrupt message, or one from
    before the recorder bounded frame ids) is processed; the trial's quality names the ignored message."""
    cam = walk.rig.names[0]
    stray = {"camera": cam, "frame_id": 2**40, "timestamp_ns": 1, "skeleton": walk.skeleton.name, "people": []}
    state, quality, steps = _processed_with(tmp_path, walk, monkeypatch, [(cam, json.dumps(stray).encode(), 2**40)])
    assert state == "done_with_warnings" and steps
    assert quality["warnings"] == [f"Camera {cam}: 1 keypoint message with a frame id far outside the recording "
                                   "(1099511627776) was ignored"]
    assert quality["ignored_keypoints"] == {cam: {"strays": 1, "stray_frame_ids": [2**40], "mistimed": 0,
                                                  "unreadable": {}}}


def test_unreadable_keypoint_messages_are_ignored_and_named_in_the_trials_quality(tmp_path, walk, monkeypatch):
    """A recording holding two keypoint messages without a skeleton and one that is not JSON is processed,
    not refused; the trial's quality says how many of which camera's messages were ignored and why."""
    cam = walk.rig.names[2]
    no_skeleton = [(cam, json.dumps({"camera": cam, "frame_id": fid, "timestamp_ns": 1, "people": []}).encode(), fid)
                   for fid in (3, 4)]
    state, quality, steps = _processed_with(tmp_path, walk, monkeypatch, [*no_skeleton, (cam, b'{"camera": "', 5)])
    assert state == "done_with_warnings" and steps
    assert quality["warnings"] == [f"Camera {cam}: 3 keypoint messages could not be read and were ignored "
                                   "(2 missing 'skeleton', 1 not JSON)"]
    assert quality["ignored_keypoints"] == {cam: {"strays": 0, "stray_frame_ids": [], "mistimed": 0,
                                                  "unreadable": {"missing 'skeleton'": 2, "not JSON": 1}}}


def test_a_camera_moved_since_calibration_flags_the_trial_and_its_checks_are_stored(tmp_path):
    """The one path's checks (once the results are stored) on a real trial MCAP whose recorded calibration is stale for one camera (turned
    2 deg after calibration): the rig check names it, the trial ends with warnings; the reconstruction is
    one person; each stage's consistency rules travel with its numbers."""
    from dataclasses import replace

    from gaitcap.simulator import make_trial
    from gaitcap.simulator.rig_faults import with_camera_moved

    walk = make_trial(preset="paper", seconds=10.0, cameras=6, seed=3)
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    write_trial_mcap(replace(walk, rig=with_camera_moved(walk.rig, "cam03", rotation_deg=2.0)),
                     Path(t.recording_path))  # the stale calibration
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    trial = cat.get_trial(db, t.id)
    assert trial.state == "done_with_warnings", trial
    gait = json.loads(trial_files(tmp_path, t.id).stage_file("preliminary", "gait_json").read_text())
    checks = cat.get_quality(db, t.id)["processing"]["checks"]  # they follow the stored results
    assert checks == json.loads(trial_files(tmp_path, t.id).checks_json.read_text())
    assert checks["rig"]["moved"] == ["cam03"], checks["rig"]
    assert abs(checks["rig"]["cameras"]["cam03"]["rotation_deg"] - 2.0) < 0.5, checks["rig"]["cameras"]["cam03"]
    assert not checks["one_person"]["mixed"], checks["one_person"]
    assert any("Camera cam03 appears to have moved" in w for w in cat.warnings_of(cat.get_quality(db, t.id)))
    stored = cat.get_result(db, t.id, "preliminary").report["consistency"]
    assert stored == gait["consistency"] and stored["rules_checked"] and stored["comparisons"] > 0, stored


def test_a_refined_fit_the_data_refuse_leaves_the_preliminary_results_and_flags_the_trial(tmp_path, walk):
    """A joint seen by one camera only in every frame: the preliminary triangulation stores the other joints,
    the refined fit refuses (nothing to fit that joint to); the trial keeps its preliminary results, ends
    ``done_with_warnings`` saying why, and is never ``failed`` with a result in hand."""
    from dataclasses import replace

    kp = walk.detections.one_person.copy()
    j = walk.detections.skeleton.joint_names.index("left_shoulder")
    kp[1:, :, j, 2] = 0.0  # every camera but the first: not seen
    one_view = replace(walk, detections=replace(walk.detections, keypoints=kp[:, :, None]))
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    write_trial_mcap(one_view, Path(t.recording_path))
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=True, lease_s=5), db=db).run_once()
    trial = cat.get_trial(db, t.id)
    assert trial.state == "done_with_warnings", (trial.state, trial.error)
    assert cat.get_result(db, t.id, "preliminary").method == "robust triangulation"
    assert cat.get_result(db, t.id, "refined") is None
    warnings = cat.warnings_of(cat.get_quality(db, t.id))
    said = [w for w in warnings if w.startswith("The refined reconstruction failed")]
    assert len(said) == 1 and "left_shoulder" in said[0] and "the preliminary results are shown" in said[0], warnings
    checks = json.loads(trial_files(tmp_path, t.id).checks_json.read_text())
    assert "left_shoulder" in checks["stages"]["failed"]["refined"], checks["stages"]


def test_the_frames_the_live_detector_missed_are_detected_before_the_refined_stage(tmp_path):
    """Completion in the one path: a recording whose live keypoints miss a third of one camera's frames and
    a 2 s stretch of another's is completed from its images (the simulated detector, which looks the
    synthetic world up by camera and frame) before the refined stage; the preliminary result rests on the
    live keypoints, the refined on the complete set and says so; the keypoints are stored with their
    provenance."""
    from gaitcap.acquisition.detectors.simulated import SimulatedConfig
    from gaitcap.acquisition.readers import load_multi_npz
    from gaitcap.services.processing.completion import CompletionSettings
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    walk = make_trial("clean", seconds=10, cameras=4, people=1, seed=3, fps=30)
    live = np.ones(walk.detections.one_person.shape[:2], bool)
    live[1, ::3] = False  # cam02: every third frame missed
    live[0, 60:120] = False  # cam01: two seconds missed
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
    write_keypoint_recording(walk, Path(t.recording_path), stills=True, live=live)
    cat.set_state(db, t.id, "recorded")
    cat.enqueue_job(db, t.id)
    completion = CompletionSettings(SimulatedConfig(walk), workers=0)
    cfg = WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=True, completion=completion)
    assert Worker(cfg, db=db).run_once()
    assert cat.get_trial(db, t.id).state in ("done", "done_with_warnings")
    prelim, refined = cat.get_result(db, t.id, "preliminary"), cat.get_result(db, t.id, "refined")
    assert prelim.method == "robust triangulation"
    assert refined.method == "implicit trajectory fit (keypoints completed after Stop)"
    done = refined.report["data_quality"]["checks"]["completion"]
    assert done["frames"]["completed"] == int((~live).sum()) and done["complete"], done["frames"]
    assert done["cameras"]["cam02"]["live"] == int(live[1].sum()) and done["warnings"] == [], done
    assert "completion" not in prelim.report["data_quality"]["checks"]
    live_key, completed_key = params_key(Implicit()), params_key(Implicit(), inputs=COMPLETED)
    assert store.get_result(db, t.id, "robust", params_key(Robust())).stage == "preliminary"  # the live keypoints
    assert store.get_result(db, t.id, "implicit", live_key) is None  # never the key of the live keypoints alone
    assert store.get_result(db, t.id, "implicit", completed_key).stage == "refined"
    kp = load_multi_npz(trial_files(tmp_path, t.id).root / "keypoints_complete.npz")
    assert kp.keypoints.shape[:2] == live.shape
    errors = _step_length_errors(refined, walk.truth.steps)  # the refined numbers on the complete keypoints
    assert len(errors) >= 6 and np.abs(errors).max() < 3.0, errors


def test_a_trial_whose_live_detector_caught_nothing_is_detected_from_its_images_and_says_so(tmp_path):
    """The detector node down for the whole trial: no keypoint message, every image recorded. Without a
    completion detector the trial fails saying the images are kept and how to detect them; with one, every
    frame is detected from the images before the first stage, both stages rest on them and say so, and the
    trial is flagged (never ``done`` as if the live pass had worked)."""
    from gaitcap.acquisition.detectors.simulated import SimulatedConfig
    from gaitcap.services.processing.completion import CompletionSettings
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.recording import write_keypoint_recording

    walk = make_trial("clean", seconds=6, cameras=3, people=1, seed=4, fps=30)
    nothing = np.zeros(walk.detections.one_person.shape[:2], bool)
    db = cat.open_catalog(tmp_path / "catalog.sqlite")
    ids = []
    for _ in range(2):
        t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: tmp_path / f"{tid}.mcap")
        write_keypoint_recording(walk, Path(t.recording_path), stills=True, live=nothing)
        cat.set_state(db, t.id, "recorded")
        ids.append(t.id)
    cat.enqueue_job(db, ids[0])
    assert Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False), db=db).run_once()
    failed = cat.get_trial(db, ids[0])
    assert failed.state == "failed" and "no keypoints recorded" in failed.error, failed.error
    assert "images are kept" in failed.error and "--complete-with" in failed.error, failed.error
    assert Path(failed.recording_path).is_file()  # the recording is never lost
    cat.enqueue_job(db, ids[1])
    completion = CompletionSettings(SimulatedConfig(walk), workers=0)
    cfg = WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=True, completion=completion)
    assert Worker(cfg, db=db).run_once()
    trial = cat.get_trial(db, ids[1])
    assert trial.state == "done_with_warnings", (trial.state, trial.error)
    for stage in ("preliminary", "refined"):
        result = cat.get_result(db, ids[1], stage)
        assert result.method.endswith("(keypoints completed after Stop)"), result.method
        errors = _step_length_errors(result, walk.truth.steps)
        assert len(errors) >= 3 and np.abs(errors).max() < 3.0, (stage, errors)
    done = cat.get_quality(db, ids[1])["processing"]["checks"]["completion"]
    assert done["frames"]["completed"] == done["frames"]["recorded"] == nothing.size, done["frames"]
    assert done["warnings"][0].startswith("No live keypoints were recorded"), done["warnings"]
    assert (trial_files(tmp_path, ids[1]).root / "keypoints_complete.npz").is_file()


def test_a_worker_grown_past_its_memory_limit_stops_after_the_job_to_be_started_afresh(tmp_path, walk):
    import threading

    from gaitcap.services.processing.worker import resident_mb

    db, tid = _recorded_trial(tmp_path, walk)
    assert 10 < resident_mb() < 1e6  # this process's resident memory, MB
    w = Worker(WorkerConfig(catalog_url=db.url, data_dir=tmp_path, refine=False, max_rss_mb=1.0), db=db)
    assert w.run(threading.Event()) == "recycle"  # after the job, never in the middle of one
    assert cat.get_trial(db, tid).state in ("done", "done_with_warnings")
    with pytest.raises(ValueError, match="max_rss_mb"):
        WorkerConfig(catalog_url=db.url, data_dir=tmp_path, max_rss_mb=0)
