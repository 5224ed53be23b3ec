"""The rig check from the patient's keypoints and the refinement of a rig from people, on the synthetic
clinic (exact ground truth): one camera's calibration made stale by a known rotation or shift."""

from __future__ import annotations

import numpy as np
import pytest
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg, rvec_of
from gaitcap.reconstruction.calibration.people_bundle import PeopleBundleConfig, refine_rig_from_people
from gaitcap.reconstruction.calibration.rig_check import check_rig
from gaitcap.reconstruction.camera import Rig, rodrigues_to_matrix
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.simulator import make_trial
from gaitcap.simulator.rig_faults import seen_from

MOVED = "cam03"


@pytest.fixture(scope="module")
def trial():
    return make_trial(preset="paper", seconds=10.0, cameras=6, seed=3)


def stale(rig: Rig, name: str, *, rotation_deg: float = 0.0, shift_mm: float = 0.0) -> Rig:
    """The rig as calibrated before camera ``name`` was turned by ``rotation_deg`` (about a tilted axis) and
    its centre moved by ``shift_mm``: the calibration no longer matches the camera."""
    axis = np.array([0.3, 1.0, 0.2]) / np.linalg.norm([0.3, 1.0, 0.2])
    cams = []
    for cam in rig:
        if cam.name == name:
            rot = rodrigues_to_matrix(np.radians(rotation_deg) * axis) @ cam.rotation
            centre = cam.center_mm + shift_mm * np.array([0.6, -0.8, 0.0])
            cam = cam.replace(rvec=rvec_of(rot), tvec_mm=-rot @ centre)
        cams.append(cam)
    return Rig(tuple(cams))


def run_check(trial, calib: Rig, **kw):
    points = robust_triangulate(trial.detections, calib).points_mm
    return check_rig(trial.detections, calib, points, **kw)


def test_unmoved_rig_is_not_flagged(trial):
    check = run_check(trial, trial.rig, expected_px={"cam01": 0.4})
    assert not check.flagged, check.warnings
    assert all(c.judged for c in check.cameras)
    assert max(c.field_px for c in check.cameras) < 2.0
    assert check.camera("cam01").expected_px == 0.4
    d = check.to_dict()
    assert d["flagged"] is False and set(d["cameras"]) == set(trial.rig.names)


def test_rotated_camera_is_named_with_its_rotation(trial):
    calib = stale(trial.rig, MOVED, rotation_deg=1.0)
    check = run_check(trial, calib)
    assert check.moved == (MOVED,), [(c.name, c.field_px, c.field_se_px) for c in check.cameras]
    est = check.camera(MOVED)
    true_turn = trial.rig[MOVED].rotation @ calib[MOVED].rotation.T
    err = rotation_angle_deg(rodrigues_to_matrix(np.radians(est.turn_deg)), true_turn)
    assert err < 0.3
    assert_within_bounds(est, true_turn)
    assert max(est.rotation_bound_deg) < 0.5 and est.shift_bound_mm < 30.0  # a walking patient determines it
    assert est.refit_residual_px < 0.8 * est.residual_px  # the refitted pose explains a large share
    assert any(MOVED in w and "deg" in w and "mm" in w for w in check.warnings)


def assert_within_bounds(est, true_turn: np.ndarray) -> None:
    """The estimated rotation's error about each camera axis (x, y, optical) lies within the check's bound."""
    err = np.degrees(rvec_of(rodrigues_to_matrix(np.radians(est.turn_deg)) @ true_turn.T))
    assert np.all(np.abs(err) <= np.asarray(est.rotation_bound_deg)), (err, est.rotation_bound_deg)


def test_the_estimates_bounds_hold_on_a_rig_as_calibrated(trial):
    """No camera moved: every camera's estimated rotation (the truth: none) lies within its bounds, and
    its estimated shift within the shift bound; the floor is the unmoved cameras' median field."""
    check = run_check(trial, trial.rig)
    median = np.median([c.field_px for c in check.cameras])
    assert all(c.floor_px == pytest.approx(max(median, c.field_se_px)) for c in check.cameras)
    for cam in check.cameras:
        assert_within_bounds(cam, np.eye(3))
        assert cam.shift_mm <= cam.shift_bound_mm, (cam.name, cam.shift_mm, cam.shift_bound_mm)
        assert set(cam.to_dict()) >= {"rotation_bound_deg", "shift_bound_mm", "floor_px"}


def test_a_refit_the_frames_do_not_pin_down_gets_bounds_as_wide():
    """On this unmoved 10-camera clinic one camera's refit swings from block to block of frames (a field of
    12 px with a standard error of 13 px, a turn of almost 2 deg): it is not flagged, and its bounds, from
    its own standard error, still hold its estimate; every other camera's too."""
    walk = make_trial(preset="paper", seconds=20.0, cameras=10, seed=4)
    check = run_check(walk, walk.rig)
    assert not check.flagged
    unsure = max(check.cameras, key=lambda c: c.field_se_px)
    assert unsure.rotation_deg > 1.0 and unsure.floor_px == unsure.field_se_px  # the case this is about
    for cam in check.cameras:
        assert_within_bounds(cam, np.eye(3))
        assert cam.shift_mm <= cam.shift_bound_mm, (cam.name, cam.shift_mm, cam.shift_bound_mm)


def test_shifted_camera_is_flagged(trial):
    check = run_check(trial, stale(trial.rig, MOVED, shift_mm=20.0))
    assert check.moved == (MOVED,)
    assert 10.0 < check.camera(MOVED).shift_mm < 40.0


def test_bad_input_is_named(trial):
    points = robust_triangulate(trial.detections, trial.rig).points_mm
    with pytest.raises(ValueError, match="points_mm"):
        check_rig(trial.detections, trial.rig, points[:-1])
    det = trial.detections
    two = type(det).of_one_person(det.one_person[:2], det.camera_names[:2], det.times_s, det.skeleton)
    with pytest.raises(ValueError, match="at least 3 cameras"):
        check_rig(two, trial.rig, points)


def test_refinement_brings_the_moved_camera_back(trial):
    calib = stale(trial.rig, MOVED, rotation_deg=2.0, shift_mm=20.0)
    result = refine_rig_from_people([trial.detections], calib, config=PeopleBundleConfig(max_frames=60))
    back = rotation_angle_deg(result.rig[MOVED].rotation, trial.rig[MOVED].rotation)
    assert back < 0.3
    assert np.linalg.norm(result.rig[MOVED].center_mm - trial.rig[MOVED].center_mm) < 20.0
    report = result.report
    assert report.median_after_px < report.median_before_px
    assert report.to_dict()["change_from_prior"][MOVED]["rotation_deg"] > 1.5


def halves(det):
    """The trial's first and second half (a reference trial and a later one, the same rig)."""
    mid = det.shape[1] // 2
    return det.frames(slice(None, mid)), det.frames(slice(mid, None))


def test_against_a_baseline_trial_the_turned_camera_is_named_with_the_turn_since(trial):
    """The first half recorded before camera MOVED turned (so seen from its calibrated pose), the second
    after: judged against the first, MOVED is flagged with its turn; with nothing moved, nothing."""
    first, second = halves(trial.detections)
    check = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm, baseline=first)
    assert not check.flagged, [(c.name, c.field_px, c.field_se_px) for c in check.cameras]
    calib = stale(trial.rig, MOVED, rotation_deg=1.0)
    baseline = seen_from(first, trial.rig, calib, MOVED)
    check = check_rig(second, calib, robust_triangulate(second, calib).points_mm, baseline=baseline)
    assert check.moved == (MOVED,), [(c.name, c.field_px, c.field_se_px) for c in check.cameras]
    true_turn = trial.rig[MOVED].rotation @ calib[MOVED].rotation.T
    assert rotation_angle_deg(rodrigues_to_matrix(np.radians(check.camera(MOVED).turn_deg)), true_turn) < 0.3


def test_a_camera_the_baseline_cannot_judge_is_judged_without_it_and_said(trial):
    first, second = halves(trial.detections)
    check = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm, baseline=first)
    # the synthetic detector leaves no camera a field with the calibration as is: nothing to subtract
    assert {c.baseline for c in check.cameras} == {"no field there"} and not any("baseline" in w for w in check.warnings)
    blind = first.one_person.copy()
    blind[1, :, :, 2] = 0.0  # the baseline trial never saw the patient in camera 2: nothing to compare with
    blind = type(first).of_one_person(blind, first.camera_names, first.times_s, first.skeleton)
    check = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm, baseline=blind)
    name = trial.rig.names[1]
    assert check.camera(name).judged and check.camera(name).baseline == "not judged there"
    assert [c.name for c in check.cameras if c.baseline != "no field there"] == [name]
    assert any(f"camera(s) {name} saw too few of the patient's keypoints in the baseline" in w
               for w in check.warnings), check.warnings
    no_baseline = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm)
    assert {c.baseline for c in no_baseline.cameras} == {"none"}


def test_a_field_the_detector_leaves_is_subtracted_and_not_taken_for_a_move(trial):
    """A detector that places one camera's joints 8 px off (a real detector's view-dependent bias) in the
    baseline trial and the trial alike: judged alone, that camera shows the field; judged against the
    baseline, it is compared and not flagged, and a turn of another camera is still named."""
    first, second = halves(trial.detections)
    biased = trial.rig.names[2]

    def with_bias(det):
        kp = det.one_person.copy()
        kp[2, ..., 0] += 8.0
        return type(det).of_one_person(kp, det.camera_names, det.times_s, det.skeleton)

    first, second = with_bias(first), with_bias(second)
    plain = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm)
    assert plain.camera(biased).field_px > 5.0
    check = check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm, baseline=first)
    assert not check.flagged and check.camera(biased).baseline == "compared"
    assert check.camera(biased).field_px < 2.0, check.camera(biased)
    calib = stale(trial.rig, MOVED, rotation_deg=1.0)
    check = check_rig(second, calib, robust_triangulate(second, calib).points_mm,
                      baseline=seen_from(first, trial.rig, calib, MOVED))
    assert check.moved == (MOVED,) and check.camera(biased).baseline == "compared"


def test_a_baseline_without_one_of_the_cameras_is_refused(trial):
    first, second = halves(trial.detections)
    short = type(first).of_one_person(first.one_person[1:], first.camera_names[1:], first.times_s, first.skeleton)
    with pytest.raises(ValueError, match=f"baseline trial lacks camera.*{trial.rig.names[0]}"):
        check_rig(second, trial.rig, robust_triangulate(second, trial.rig).points_mm, baseline=short)


POSE2SIM_PARTICIPANT = share_path("testdata", "pose2sim", "S00_Demo_BatchSession", "S00_P00_SingleParticipant")


def _pose2sim(trial: str):
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.services.processing.pipeline import patient_input, resolve_layout

    data = read_keypoints_input(POSE2SIM_PARTICIPANT / trial)
    recording, _ = resolve_layout(data.recording, data.rig, named=data.layout)
    det, rig, _ = patient_input(recording, data.rig)
    return det, rig


@pytest.mark.skipif(not POSE2SIM_PARTICIPANT.is_dir(), reason="Pose2Sim demo recordings not installed (deploy/bootstrap.sh)")
def test_real_demo_turned_camera_is_blamed_on_it_against_the_sessions_static_trial():
    """Pose2Sim's real demo (4 cameras, OpenPose): the detector leaves cam_01 and cam_03 fields of 25-35 px
    with the calibration as is, as large as a 1 deg turn. Judged against the participant's static trial
    of the same session, the balancing trial is not flagged as calibrated, and with cam_02's calibration
    2 deg off (the static trial recorded before it turned) cam_02 alone is flagged."""
    det, rig = _pose2sim("S00_P00_T01_BalancingTrial")
    static, _ = _pose2sim("S00_P00_T00_StaticTrial")
    as_given = check_rig(det, rig, robust_triangulate(det, rig).points_mm, baseline=static)
    assert not as_given.flagged, [(c.name, c.field_px, c.field_se_px) for c in as_given.cameras]
    calib = stale(rig, "cam_02", rotation_deg=2.0)
    check = check_rig(det, calib, robust_triangulate(det, calib).points_mm,
                      baseline=seen_from(static, rig, calib, "cam_02"))
    assert check.moved == ("cam_02",), [(c.name, c.field_px, c.field_se_px) for c in check.cameras]
    assert check.camera("cam_01").baseline == check.camera("cam_03").baseline == "compared"  # 25-35 px fields
    # a person balancing in place does not tell a turn from a shift of the centre: the estimate says so
    est = check.camera("cam_02")
    assert_within_bounds(est, rig["cam_02"].rotation @ calib["cam_02"].rotation.T)
    assert min(est.rotation_bound_deg) > 1.0 and est.shift_bound_mm > 100.0
    warning = next(w for w in check.warnings if "cam_02" in w)
    assert f"within {max(est.rotation_bound_deg[:2]):.1f} deg in pan and tilt" in warning


def test_refinement_of_the_flagged_camera_alone_keeps_the_others(trial):
    """With the camera the check flagged named as moved, only it is adjusted: every other camera keeps its
    calibration exactly, and the moved one comes back as close as with every camera adjusted."""
    calib = stale(trial.rig, MOVED, rotation_deg=2.0, shift_mm=20.0)
    result = refine_rig_from_people([trial.detections], calib, moved=(MOVED,),
                                    config=PeopleBundleConfig(max_frames=60))
    for cam in calib:
        if cam.name != MOVED:
            np.testing.assert_array_equal(result.rig[cam.name].rvec, cam.rvec)
            np.testing.assert_array_equal(result.rig[cam.name].tvec_mm, cam.tvec_mm)
    assert rotation_angle_deg(result.rig[MOVED].rotation, trial.rig[MOVED].rotation) < 0.3
    assert np.linalg.norm(result.rig[MOVED].center_mm - trial.rig[MOVED].center_mm) < 20.0
    with pytest.raises(ValueError, match="moved camera.*'cam99'.*not in the calibration"):
        refine_rig_from_people([trial.detections], calib, moved=("cam99",))
