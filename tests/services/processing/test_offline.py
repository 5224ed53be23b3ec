"""Recordings made by other tools, through the worker's processing path: real Pose2Sim recordings (one and
two people, 4 cameras, BODY_25B), layouts recognised, the patient kept across frames, bad input refused."""

import json
import shutil
from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
from gaitcap.acquisition.installed import share_path
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.services.cli import app
from gaitcap.services.processing.pipeline import patient_input, preliminary, resolve_layout
from typer.testing import CliRunner

DEMOS = share_path("testdata", "pose2sim")
SESSION = DEMOS / "S00_Demo_BatchSession"
TWO_PEOPLE = SESSION / "S00_P01_MultiParticipants" / "S00_P01_T02_Participants1-2"
ONE_PERSON = SESSION / "S00_P00_SingleParticipant" / "S00_P00_T01_BalancingTrial"
needs_demos = pytest.mark.skipif(not TWO_PEOPLE.is_dir(), reason="Pose2Sim demo recordings not installed "
                                 "(run deploy/bootstrap.sh)")


def pelvis_jumps_mm(points_mm: np.ndarray, skeleton: str) -> np.ndarray:
    """Frame-to-frame displacement (mm) of the hips' midpoint (NaN where either frame lacks it)."""
    s = get_skeleton(skeleton)
    mid = 0.5 * (points_mm[:, s.index("left_hip")] + points_mm[:, s.index("right_hip")])
    return np.linalg.norm(np.diff(mid, axis=0), axis=-1)


def limb_sd_mm(points_mm: np.ndarray, skeleton: str) -> float:
    """Median over the skeleton's limbs of the SD of the limb's length (mm)."""
    s = get_skeleton(skeleton)
    sds = [np.nanstd(np.linalg.norm(points_mm[:, a] - points_mm[:, b], axis=-1)) for a, b in s.limb_indices]
    return float(np.nanmedian(sds))


@needs_demos
def test_qualisys_calibration_is_converted_as_pose2sim_does(tmp_path):
    """Pose2Sim's own conversion of this calibration ships beside it (its cam_01 is a moving camera)."""
    from gaitcap.acquisition.importers.tool_folders import read_qca
    from gaitcap.acquisition.readers import load_rig

    ours = read_qca(SESSION / "S00_Calibration" / "Calib.qca.txt")
    text = (SESSION / "S00_Calibration" / "Calib_qualisys_multi.test").read_text()
    (tmp_path / "theirs.toml").write_text(text[text.index("[cam_02]"):])
    theirs = load_rig(tmp_path / "theirs.toml")
    assert list(theirs.names) == ["cam_02", "cam_03", "cam_04"]
    for cam in theirs.cameras:
        mine = ours.cameras[ours.names.index(cam.name)]
        np.testing.assert_allclose(mine.matrix_px, cam.matrix_px, rtol=1e-9)
        np.testing.assert_allclose(mine.dist[:4], cam.dist[:4], rtol=1e-9)
        np.testing.assert_allclose(mine.rvec, cam.rvec, atol=1e-6)
        np.testing.assert_allclose(mine.tvec_mm, cam.tvec_mm, atol=1e-3)


@needs_demos
def test_two_real_people_the_patient_stays_the_same_person(tmp_path):
    data = read_keypoints_input(TWO_PEOPLE)
    assert data.layout == "body25b" and data.rig is not None  # from the session's Config.toml and calibration
    assert data.recording.times_s[1] == pytest.approx(1 / 60)  # its frame_rate
    recording, layout = resolve_layout(data.recording, data.rig, named=data.layout)
    assert layout.margin_mm > 100, layout.evidence()  # BODY_25 is far off
    det, rig, selection = patient_input(recording, data.rig)
    assert selection is not None and selection.tracks.num_tracks >= 2
    walker = preliminary(det, rig).points_mm
    jumps = pelvis_jumps_mm(walker, "body25b")
    assert np.isfinite(jumps).mean() > 0.9
    assert int((jumps > 150).sum()) == 0  # no frame where the reconstruction switches person (60 fps)
    assert limb_sd_mm(walker, "body25b") < 25
    other = next(t for t in selection.tracks.ids if t != selection.track_id)
    from gaitcap.reconstruction.association import ManualTrack

    det2, _, chosen = patient_input(recording, data.rig, selector=ManualTrack(int(other)))
    assert chosen.track_id == other
    second = preliminary(det2, rig).points_mm
    apart = np.nanmedian(np.linalg.norm(np.nanmean(walker, 1) - np.nanmean(second, 1), axis=-1))
    assert apart > 300  # the other participant, not the same one again


@needs_demos
def test_real_body25b_without_a_config_is_recognised(tmp_path, caplog):
    """The issue's case: OpenPose BODY_25B JSON with nothing saying so is not read as BODY_25."""
    from gaitcap.acquisition.importers.tool_folders import read_qca

    shutil.copytree(ONE_PERSON / "pose", tmp_path / "pose")
    save_rig(read_qca(SESSION / "S00_Calibration" / "Calib.qca.txt"), tmp_path / "calib.toml")
    from gaitcap.acquisition.readers import load_rig

    rig = load_rig(tmp_path / "calib.toml")
    data = read_keypoints_input(tmp_path / "pose", rig=rig, fps=60)
    assert data.layout is None
    recording, layout = resolve_layout(data.recording, rig, named=None)
    assert layout.skeleton == "body25b" and layout.how == "recognised", layout.evidence()
    assert layout.score_of("body25b").limb_sd_mm < 25 and layout.margin_mm > 100
    _, warned = resolve_layout(data.recording, rig, named="body25")  # an explicit wrong layout: kept, warned
    assert warned.skeleton == "body25" and "--skeleton body25 looks inconsistent" in warned.warnings[0]


def _synthetic_body25b_folder(root: Path):
    """A synthetic walk written as OpenPose BODY_25B JSON (one folder per camera), and its calibration."""
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.layouts import points_in_layout

    trial = make_trial(preset="paper", seconds=4.0, cameras=4, seed=5)
    pts = points_in_layout(trial.points_mm, "body25b")
    px = trial.rig.project(pts) + np.random.default_rng(0).normal(0, 1.0, (4, *pts.shape[:2], 2))
    for c, cam in enumerate(trial.rig.names):
        folder = root / f"{cam}_json"
        folder.mkdir(parents=True)
        for t in range(pts.shape[0]):
            kp = np.concatenate([px[c, t], np.full((25, 1), 0.9)], -1)
            doc = {"version": 1.3, "people": [{"person_id": [-1], "pose_keypoints_2d": kp.reshape(-1).tolist()}]}
            (folder / f"walk_{t:012d}_keypoints.json").write_text(json.dumps(doc))
    save_rig(trial.rig, root.parent / "calib.toml")
    return trial


def test_process_command_recognises_the_layout_and_writes_the_workers_files(tmp_path):
    _synthetic_body25b_folder(tmp_path / "pose")
    out = tmp_path / "out"
    res = CliRunner().invoke(app, ["process", str(tmp_path / "pose"), "--calibration", str(tmp_path / "calib.toml"),
                                   "--out", str(out), "--no-refine", "--json"])
    assert res.exit_code == 0, res.output
    summary = json.loads(res.stdout.strip().splitlines()[-1])
    assert summary["layout"]["skeleton"] == "body25b" and summary["layout"]["how"] == "recognised"
    assert "next best body25" in summary["layout"]["evidence"]
    assert summary["people"] is None and summary["frames"] == 120
    stage = summary["stages"]["preliminary"]
    assert stage["method"] == "robust triangulation"
    for name in ("trajectory.npz", "trajectory.trc", "report.png", "trajectory.rrd"):
        assert (out / "preliminary" / name).is_file(), name
    with np.load(out / "preliminary" / "trajectory.npz") as z:
        assert list(z["joint_names"]) == list(get_skeleton("body25b").joint_names)
        assert limb_sd_mm(z["points_mm"], "body25b") < 10
    assert "NaN" not in res.stdout


def test_no_usable_observation_is_an_error_and_nothing_is_written(tmp_path):
    from gaitcap.reconstruction.camera import Camera, Rig

    rig = Rig(tuple(Camera(f"cam{i}", (640, 480), np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
                           tvec_mm=np.array([i * 500.0, 0, 3000])) for i in range(3)))
    save_rig(rig, tmp_path / "calib.toml")
    kp = np.random.default_rng(0).uniform(100, 400, (3, 40, 26, 3))
    kp[..., 2] = 0.0  # every confidence zero
    np.savez(tmp_path / "zero.npz", keypoints=kp, cameras=np.array(rig.names))
    runner = CliRunner()
    res = runner.invoke(app, ["reconstruct", "--calibration", str(tmp_path / "calib.toml"), "--keypoints",
                              str(tmp_path / "zero.npz"), "--method", "robust", "--out", str(tmp_path / "r.npz")])
    assert res.exit_code == 2 and "no usable observation" in res.output and "cam0, cam1, cam2" in res.output
    assert "0.1" in res.output and not (tmp_path / "r.npz").exists()
    res = runner.invoke(app, ["process", str(tmp_path / "zero.npz"), "--calibration", str(tmp_path / "calib.toml"),
                              "--out", str(tmp_path / "out")])
    assert res.exit_code == 2 and "no usable observation" in res.output and not (tmp_path / "out").exists()
    kp[0, :, :, 2] = 0.9  # one camera sees everything: still no joint seen twice
    np.savez(tmp_path / "one.npz", keypoints=kp, cameras=np.array(rig.names))
    res = runner.invoke(app, ["process", str(tmp_path / "one.npz"), "--calibration", str(tmp_path / "calib.toml"),
                              "--out", str(tmp_path / "out")])
    assert res.exit_code == 2 and "no joint is seen by two cameras" in res.output
    assert "cam0: 26 joints" in res.output and not (tmp_path / "out").exists()


def test_real_videos_of_two_people_give_one_consistent_walker(tmp_path):
    """Pose2Sim's 4-camera videos of two people (16 frames at half size; fewer make no track): everyone is detected, one person
    is reconstructed in every frame, limbs consistent."""
    import cv2
    from gaitcap.acquisition.detectors.mediapipe import default_model_dir
    from gaitcap.acquisition.importers.tool_folders import read_qca
    from gaitcap.services.cli.detect import build_detector
    from gaitcap.services.processing.offline import detect_input
    from gaitcap.simulator.board import scaled_rig

    videos = DEMOS / "Demo_MultiPerson" / "videos"
    if not videos.is_dir() or not (default_model_dir() / "pose_landmark_full.tflite").is_file():
        pytest.skip("Pose2Sim demo videos or MediaPipe models not installed (run deploy/bootstrap.sh)")
    for f in sorted(videos.glob("*.mp4")):
        cap = cv2.VideoCapture(str(f))
        cap.set(cv2.CAP_PROP_POS_FRAMES, 12)
        out = None
        for _ in range(16):
            ok, img = cap.read()
            assert ok
            img = cv2.resize(img, None, fx=0.5, fy=0.5, interpolation=cv2.INTER_AREA)
            out = out or cv2.VideoWriter(str(tmp_path / f"{f.stem}.avi"), cv2.VideoWriter_fourcc(*"MJPG"), 60,
                                         (img.shape[1], img.shape[0]))
            out.write(img)
        out.release()
    rig = scaled_rig(read_qca(DEMOS / "Demo_MultiPerson" / "calibration" / "Calib.qca.txt"), 0.5)
    data = detect_input(tmp_path, build_detector("mediapipe", None, ["num_poses=3"]), fps=None, on_frame=None)
    seen = (np.nan_to_num(data.recording.keypoints[..., 2]) > 0.3).any(-1).sum(-1)  # (C, T) people per image
    assert seen.max() == 2 and (seen == 2).sum() >= 16  # both people kept, in many camera frames
    recording, layout = resolve_layout(data.recording, rig, named=data.layout)
    det, used, _ = patient_input(recording, rig)
    walker = preliminary(det, used).points_mm
    jumps = pelvis_jumps_mm(walker, "mediapipe33")
    assert np.isfinite(jumps).all() and jumps.max() < 150  # the same person in every frame
    assert limb_sd_mm(walker, "mediapipe33") < 40


@needs_demos
def test_reconstruct_command_chooses_and_reports_the_patient(tmp_path):
    runner = CliRunner()
    base = ["reconstruct", "--keypoints", str(TWO_PEOPLE), "--method", "dlt"]  # the folder's own calibration
    auto = runner.invoke(app, base + ["--out", str(tmp_path / "auto.npz")])
    assert auto.exit_code == 0, auto.output
    assert "2 people tracked" in auto.output and "* track 1: 100 frames" in auto.output
    assert "the patient is track 1 (automatic: the person who walks the walkway)" in auto.output
    assert "layout body25b (explicit)" in auto.output and "NaN" not in auto.output
    bad = runner.invoke(app, base + ["--out", str(tmp_path / "x.npz"), "--person", "7"])
    assert bad.exit_code == 2 and "7" in bad.output and not (tmp_path / "x.npz").exists()  # --person reaches it


def test_missing_frames_are_named_as_ranges():
    from gaitcap.reconstruction.result import Reconstruction
    from gaitcap.services.processing.offline import frame_ranges, missing_by_joint, missing_frames

    assert frame_ranges(np.array([0, 1, 2, 5, 7, 8])) == "0-2, 5, 7-8"
    points = np.zeros((6, 2, 3))
    points[[1, 2, 4], 1] = np.nan
    traj = Reconstruction("t", points, np.arange(6) / 30, ("left_heel", "right_heel"))
    assert missing_frames(traj) == {"right_heel": "1-2, 4"}
    points[3, 0, 2] = np.inf  # one coordinate not finite is a missing point
    missing = missing_by_joint(points, traj.joint_names)
    assert list(missing) == ["left_heel", "right_heel"]
    assert missing["left_heel"].tolist() == [3] and missing["right_heel"].tolist() == [1, 2, 4]
