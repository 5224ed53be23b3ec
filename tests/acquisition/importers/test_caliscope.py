"""A real calibration session: caliscope's four 1280x720 webcams and a hand-held inverted ChArUco board
(4 x 5 squares of 54 mm, DICT_4X4_1000), its corner detections and caliscope's own calibration (from the
caliscope 0.7.5 sdist, installed by deploy/bootstrap.sh)."""

import csv

import numpy as np
import pytest
from gaitcap.acquisition.boards.pairing import PairingConfig
from gaitcap.acquisition.importers.caliscope import read_camera_array, read_session
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.calibration import (
    CalibrationConfig,
    IntrinsicsConfig,
    calibrate_from_observations,
)
from gaitcap.reconstruction.calibration.compare import compare_similar
from gaitcap.reconstruction.calibration.intrinsics import DistortionModel
from gaitcap.reconstruction.calibration.whole_views import LEFT_OUT_REASON

SESSION = share_path("testdata", "calibration", "caliscope-4cam")
pytestmark = pytest.mark.skipif(not (SESSION / "calibration" / "extrinsic" / "xy.csv").exists(),
                                reason=f"caliscope session not installed in {SESSION} (run deploy/bootstrap.sh)")


@pytest.fixture(scope="module")
def session():
    return read_session(SESSION)


@pytest.fixture(scope="module")
def with_their_intrinsics(session):
    _, obs, ref, _ = session
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras}
    return calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known))


def test_board_file_and_detections(session):
    board, obs, ref, moving = session
    assert board.describe() == "charuco 4 x 5 squares of 54 mm, markers 40.5 mm DICT_4X4_1000, inverted"
    assert obs.camera_names == ("cam_0", "cam_1", "cam_2", "cam_3") == tuple(ref.names)
    assert obs.views().sum(1).tolist() == [46, 45, 42, 23]  # every view caliscope found
    # 48 frame sets, as caliscope paired them, and 3 views of a board that moved between the cameras'
    # exposures (up to 11 ms apart) taken out of their sets, each a frame of its own (intrinsics only)
    assert moving == 3 and obs.shape == (4, 48 + 3, 12)
    alone = obs.views().sum(0) == 1
    assert alone.sum() >= 3


def test_pairing_by_time_matches_caliscopes_sync_index():
    with open(SESSION / "calibration" / "extrinsic" / "xy.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    theirs = {(r["cam_id"], r["frame_index"]): r["sync_index"] for r in rows}
    board, obs, ref, _ = read_session(SESSION, pairing=PairingConfig(max_shift_px=1e9))
    # the same corner coordinates in the same set: every set of ours holds frames of one caliscope sync index
    for f in range(obs.shape[1]):
        syncs = set()
        for c in range(4):
            if obs.views()[c, f]:
                uv = obs.corners_px[c, f][np.isfinite(obs.corners_px[c, f, :, 0])][0]
                match = [theirs[(r["cam_id"], r["frame_index"])] for r in rows if r["cam_id"] == str(c)
                         and abs(float(r["img_loc_x"]) - uv[0]) < 1e-9 and abs(float(r["img_loc_y"]) - uv[1]) < 1e-9]
                syncs.update(match)
        assert len(syncs) == 1, f"set {f}: frames of caliscope sync indices {sorted(syncs)}"


def test_with_the_same_intrinsics_the_rig_matches_caliscopes(session, with_their_intrinsics):
    _, _, ref, _ = session
    report = with_their_intrinsics.report
    assert report.failed_cameras == ()
    assert all(q.reprojection_rms_px < 1.0 for q in report.cameras), [q.reprojection_rms_px for q in report.cameras]
    assert abs(report.square_measured_mm - 54.0) < 0.3  # the scale: triangulated squares
    cmp = compare_similar(ref, with_their_intrinsics.rig)
    assert abs(cmp.scale - 1) < 0.01  # both in mm from the same board
    assert cmp.centre_mm_max < 3.0 and cmp.rotation_deg_max < 0.4, (cmp.centre_mm, cmp.rotation_deg)


def test_estimating_intrinsics_from_this_clip_holds_what_it_cannot_determine(session):
    _, obs, ref, _ = session
    result = calibrate_from_observations(obs)
    rms = [q.reprojection_rms_px for q in result.report.cameras]
    assert all(r < 1.0 for r in rms), rms
    assert all(q.views_kept_fraction > 0.9 for q in result.report.cameras)
    # the board never covered more than a fifth of an image: each principal point is held at the image centre
    # (left free, camera 0's wandered 64 px: 4 deg), the report says so and why, and the rig is not refused
    assert result.report.failed_cameras == ()
    for q in result.report.cameras:
        assert len(q.held) == 1 and q.held[0].startswith("principal point held at the image centre: the board "
                                                          "covered "), q.held
        assert q.held[0] in q.notes and q.focal_rel_std < 0.15
    for cam in result.rig:
        assert np.allclose(cam.matrix_px[:2, 2], np.asarray(cam.size_px) / 2), (cam.name, cam.matrix_px)
    cmp = compare_similar(ref, result.rig)
    # the rays agree within a degree; the rotations differ by about as much as caliscope's principal points
    # lie off the image centre (1.0-2.8 deg), the centres by up to 17 mm (measured 5.6-16.3 mm)
    assert max(cmp.pointing_deg) < 1.0 and max(cmp.rotation_deg) < 3.0, (cmp.pointing_deg, cmp.rotation_deg)
    assert cmp.centre_mm_max < 18.0, cmp.centre_mm


def test_richer_distortion_is_reduced_to_k1_where_the_views_cannot_determine_it(session):
    _, obs, _, _ = session
    config = CalibrationConfig(intrinsics=IntrinsicsConfig(distortion=DistortionModel.FULL))
    result = calibrate_from_observations(obs, config=config)
    assert result.report.failed_cameras == ()
    for q in result.report.cameras:
        assert q.held[1].startswith("distortion k2, p1, p2, k3 held at 0 (only k1 fitted): the board covered"), q.held
    for cam in result.rig:
        assert cam.dist[0] != 0 and np.all(cam.dist[1:] == 0), (cam.name, cam.dist)


def test_strict_intrinsics_refuse_the_small_board_as_before(session):
    _, obs, _, _ = session
    strict = CalibrationConfig(intrinsics=IntrinsicsConfig(hold_undetermined=False))
    result = calibrate_from_observations(obs, config=strict)
    assert set(result.report.failed_cameras) == set(obs.camera_names)
    assert all(any("covered" in p for p in q.problems) and q.held == () for q in result.report.cameras)


def test_a_camera_far_above_the_others_rms_fails(session):
    _, obs, ref, _ = session
    noisy = obs.corners_px.copy()
    noisy[3] += np.random.default_rng(0).normal(0, 2.0, noisy[3].shape)
    from gaitcap.reconstruction.calibration import BoardObservations

    bad = BoardObservations(obs.camera_names, obs.image_sizes_px, noisy, obs.board, obs.times_s)
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras}
    result = calibrate_from_observations(bad, config=CalibrationConfig(known_intrinsics=known))
    assert result.report.failed_cameras == ("cam_3",)
    assert "x the other cameras' median" in " ".join(result.report.cameras[3].problems)


def test_known_intrinsics_must_name_every_camera(session):
    _, obs, ref, _ = session
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras[:3]}
    with pytest.raises(ValueError, match=r"none given for cameras \['cam_3'\]"):
        calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known))


def test_camera_array_units(session):
    rig = read_camera_array(SESSION / "camera_array.toml")
    assert np.linalg.norm(rig["cam_1"].tvec_mm) < 5  # caliscope's anchor camera, metres -> mm
    assert 1000 < np.linalg.norm(rig["cam_0"].center_mm) < 3000


SECOND = SESSION.parent / "caliscope-4cam-2"  # another recording of the same board with 4 webcams


@pytest.mark.skipif(not (SECOND / "camera_array.toml").exists(), reason=f"{SECOND} not installed")
def test_a_second_session_matches_caliscope_and_names_a_degenerate_camera():
    _, obs, ref, _ = read_session(SECOND)
    assert obs.views().sum(1).tolist() == [57, 48, 50, 38]
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras}
    result = calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known))
    assert result.report.failed_cameras == ()
    assert max(q.reprojection_rms_px for q in result.report.cameras) < 1.6  # 2D RMS: 0.80-1.43 px measured
    cmp = compare_similar(ref, result.rig)
    assert cmp.centre_mm_max < 6.0 and cmp.rotation_deg_max < 0.7, (cmp.centre_mm, cmp.rotation_deg)
    strict = CalibrationConfig(intrinsics=IntrinsicsConfig(hold_undetermined=False))
    with pytest.raises(ValueError, match="camera 'cam_3': board views are degenerate for intrinsics"):
        calibrate_from_observations(obs, config=strict)  # camera 3's focal length, principal point free: 46 %
    held = calibrate_from_observations(obs)  # with it held at the image centre and only k1: 11 %, calibrated
    assert held.report.failed_cameras == ()
    cam3 = held.report.cameras[3]
    assert cam3.held == ("principal point held at the image centre: with it free the focal length was uncertain "
                         "by 46.3 % (> 15 %)",) and 0.05 < cam3.focal_rel_std < 0.15, (cam3.held, cam3.focal_rel_std)
    # refused only when still not usable, with both figures
    tight = CalibrationConfig(intrinsics=IntrinsicsConfig(max_focal_rel_std=0.1))
    with pytest.raises(ValueError, match=r"camera 'cam_3': .*uncertain by 46.3 % with the principal point free, "
                                         r"11.\d % with it held at the image centre and only k1"):
        calibrate_from_observations(obs, config=tight)


@pytest.mark.skipif(not (SECOND / "camera_array.toml").exists(), reason=f"{SECOND} not installed")
def test_the_second_sessions_excess_error_is_the_moving_board():
    # views whose board moved more than 1 px within a 20 ms rolling-shutter readout are left out
    _, obs, ref, moving = read_session(SECOND, pairing=PairingConfig(readout_ms=20.0))
    assert 40 <= moving <= 0.5 * 193  # of 193 views, at most half of each camera's
    known = {c.name: (c.matrix_px, c.dist) for c in ref.cameras}
    result = calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known))
    rms = [q.reprojection_rms_px for q in result.report.cameras]
    # 0.80 / 1.36 / 1.42 / 1.22 px with every view; measured 0.48 / 0.82 / 0.80 / 1.03 px without the smeared
    assert max(rms) < 1.1 and sorted(rms)[2] < 0.95, rms
    # 5 of camera 1's 24 remaining views (and 1 of camera 2's) fit a board pose of their own but not the one
    # the other cameras saw (every corner an outlier): left out and counted
    left = {q.name: q.views_left_out for q in result.report.cameras if q.views_left_out}
    assert left.get("cam_1", 0) >= 4 and sum(left.values()) <= left["cam_1"] + 2, left
    assert all(q.notes[0] == f"{q.views_left_out} view{'s' * (q.views_left_out != 1)} left out: {LEFT_OUT_REASON}"
               for q in result.report.cameras if q.views_left_out), [q.notes for q in result.report.cameras]
    cmp = compare_similar(ref, result.rig)
    assert cmp.centre_mm_max < 10.0 and cmp.rotation_deg_max < 1.5, (cmp.centre_mm, cmp.rotation_deg)
    # counted against the views as found (the readout removed 24 of camera 1's 48), camera 1 is judged on
    # 19 of 48 and refused for it; the others keep more than half (that is what the session gives)
    _, every, _, _ = read_session(SECOND)
    removed = {n: int(a - b) for n, a, b in zip(obs.camera_names, every.views().sum(1), obs.views().sum(1), strict=True)}
    assert removed["cam_1"] == 24, removed
    judged = calibrate_from_observations(obs, config=CalibrationConfig(known_intrinsics=known), views_removed=removed)
    assert judged.report.failed_cameras == ("cam_1",), [q.problems for q in judged.report.cameras]
    cam1 = judged.report.cameras[1]
    assert cam1.problems == (f"judged on {cam1.n_detections} of its 48 views found (< 50 %): 24 removed before "
                             f"calibration (smeared during the readout), {cam1.views_left_out} left out as disagreeing "
                             "with the other cameras, 0 not placed in the rig",)
    assert cam1.n_detections == 48 - 24 - cam1.views_left_out
