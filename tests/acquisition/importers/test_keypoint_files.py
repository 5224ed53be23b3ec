import json
import logging

import numpy as np
import pytest
from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
from gaitcap.acquisition.importers.keypoint_input import sort_people
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.camera import Camera, Rig
from gaitcap.reconstruction.keypoints import LIVE, MISSING, MultiViewKeypoints


def _rig(names):
    return Rig(tuple(Camera(n, (640, 480), np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]])) for n in names))


def _write_openpose(root, folders, frames, people_per_frame):
    for c, folder in enumerate(folders):
        d = root / folder
        d.mkdir(parents=True)
        for f in frames:
            people = []
            for p in range(people_per_frame):
                kp = np.zeros((25, 3))
                kp[:, 0], kp[:, 1] = 100 + 10 * c + p, 200 + f
                kp[:, 2] = 0.9 if p == 1 else 0.4
                kp[3] = 0  # a joint OpenPose did not find
                people.append({"person_id": [-1], "pose_keypoints_2d": kp.reshape(-1).tolist()})
            (d / f"trial_{f:012d}_keypoints.json").write_text(json.dumps({"version": 1.3, "people": people}))


def test_openpose_folder_by_name_and_by_order(tmp_path, caplog):
    _write_openpose(tmp_path / "a", ["cam1_json", "cam0_json"], [0, 1, 2, 4], 2)
    data = read_keypoints_input(tmp_path / "a", rig=_rig(["cam0", "cam1"]), fps=25)
    assert data.layout is None and data.rig is None  # BODY_25 or BODY_25B: to be recognised
    assert data.recording.keypoints.shape == (2, 5, 2, 25, 3)
    det = data.recording.patient()  # the most confident person comes first
    assert det.camera_names == ("cam0", "cam1")
    assert det.one_person.shape == (2, 5, 25, 3)
    c0 = det.camera_names.index("cam0")
    assert det.one_person[c0, 0, 0, 0] == pytest.approx(111)  # folder cam0_json was written second (c = 1), p = 1
    assert (det.one_person[c0, 3, :, 2] == 0).all()  # frame 3 is in no folder
    assert np.isnan(det.one_person[c0, 0, 3, 0]) and det.one_person[c0, 0, 3, 2] == 0
    assert det.times_s[-1] == pytest.approx(4 / 25)
    _write_openpose(tmp_path / "b", ["x", "y"], [0, 1], 1)
    with caplog.at_level(logging.WARNING):
        det2 = read_keypoints_input(tmp_path / "b", rig=_rig(["c0", "c1"]))
    assert det2.recording.camera_names == ("c0", "c1")
    assert "matched by order" in caplog.text  # names that do not match: by order, never silently
    with pytest.raises(ValueError, match="match neither"):
        read_keypoints_input(tmp_path / "b", rig=_rig(["c0", "c1", "c2"]))


def test_npz_input(tmp_path):
    kp = np.random.default_rng(0).uniform(0, 1, (3, 4, 26, 3))
    np.savez(tmp_path / "k.npz", keypoints=kp, cameras=np.array(["a", "b", "c"]))
    data = read_keypoints_input(tmp_path / "k.npz")
    assert data.layout is None and data.recording.skeleton.name == "halpe26"  # the only 26-keypoint layout
    assert data.recording.times_s[1] == pytest.approx(1 / 30)
    np.savez(tmp_path / "named.npz", keypoints=kp[..., :25, :], cameras=np.array(["a", "b", "c"]),
             skeleton=np.array("body25b"))
    assert read_keypoints_input(tmp_path / "named.npz").layout == "body25b"
    assert read_keypoints_input(tmp_path / "named.npz", skeleton="body25").layout == "body25"  # the flag wins
    np.savez(tmp_path / "bad.npz", keypoints=kp, cameras=np.array(["a", "b"]))
    with pytest.raises(ValueError, match="2 camera names for 3 cameras"):
        read_keypoints_input(tmp_path / "bad.npz")
    np.savez(tmp_path / "nocam.npz", keypoints=kp)
    with pytest.raises(ValueError, match="cameras"):
        read_keypoints_input(tmp_path / "nocam.npz")
    abc = np.array(["a", "b", "c"])
    np.savez(tmp_path / "pct.npz", keypoints=kp * [1, 1, 100], cameras=abc)  # confidences in percent
    with pytest.raises(ValueError, match="pct.npz: keypoints: confidence .* must lie in \\[0, 1\\]"):
        read_keypoints_input(tmp_path / "pct.npz")
    np.savez(tmp_path / "times.npz", keypoints=kp, cameras=abc, times_s=np.array([0.0]))
    with pytest.raises(ValueError, match="times.npz: times_s: expected 4 times"):
        read_keypoints_input(tmp_path / "times.npz")  # never one time broadcast over every frame
    np.savez(tmp_path / "back.npz", keypoints=kp, cameras=abc, times_s=np.array([0.0, 0.1, 0.05, 0.2]))
    with pytest.raises(ValueError, match="back.npz: times_s: must be strictly increasing"):
        read_keypoints_input(tmp_path / "back.npz")
    np.savez(tmp_path / "seven.npz", keypoints=kp[..., :7, :], cameras=np.array(["a", "b", "c"]))
    with pytest.raises(ValueError, match="no known layout has 7 keypoints"):
        read_keypoints_input(tmp_path / "seven.npz")
    with pytest.raises(FileNotFoundError):
        read_keypoints_input(tmp_path / "missing.npz")


def test_people_sorted_most_confident_first():
    people = np.zeros((1, 2, 3, 4, 3))
    people[0, 0, 2, :, 2] = 0.9
    people[0, 1, 0, :, 2] = 0.5
    people[..., 0] = np.arange(3)[None, None, :, None]
    ordered = sort_people(people)
    assert ordered.shape == people.shape and ordered[0, 0, 0, 0, 0] == 2 and ordered[0, 1, 0, 0, 0] == 0
    assert sorted(ordered[0, 0, :, 0, 0]) == [0, 1, 2]  # nobody dropped


def test_trial_mcap_input(tmp_path):
    from gaitcap.acquisition.recording.writer import TrialWriter, WriterSettings
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text

    rig = _rig(["cam0", "cam1"])
    w = TrialWriter(tmp_path / "t.mcap", WriterSettings(flush_interval_s=3600))
    t0 = 1_700_000_000_000_000_000
    w.start(metadata={}, calibration_toml=rig_to_toml_text(rig), time_ns=t0)
    for f in range(3):
        for c, cam in enumerate(rig.names):
            people = np.zeros((2, 26, 3))
            people[:, :, 0] = [[10 * c + f], [500]]
            people[:, :, 2] = [[0.9], [0.3]]
            ts = t0 + f * 33_333_333
            msg = {"camera": cam, "frame_id": f, "timestamp_ns": ts, "skeleton": "halpe26", "people": people.tolist()}
            w.add_keypoints(cam, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=f)
    w.finish({})
    data = read_keypoints_input(tmp_path / "t.mcap", rig=rig)
    assert data.layout == "halpe26" and data.rig is not None and data.rig.names == rig.names
    det = data.recording.patient()
    assert det.one_person.shape == (2, 3, 26, 3) and det.skeleton.name == "halpe26"
    assert det.one_person[1, 2, 0, 0] == 12 and det.times_s[1] == pytest.approx(1 / 30, abs=1e-6)


POSE2SIM_TRIAL = share_path("testdata", "pose2sim", "S00_Demo_BatchSession", "S00_P00_SingleParticipant",
                            "S00_P00_T01_BalancingTrial")


def _as_trial_mcap(kp: MultiViewKeypoints, rig, path, *, lost: tuple[int, slice]):
    """``kp`` sent as the detector node sends keypoints (the people seen, unseen joints [0, 0, 0]) into a
    trial MCAP with ``rig``'s calibration; camera ``lost[0]``'s messages of frames ``lost[1]`` never arrive."""
    from gaitcap.acquisition.recording.writer import TrialWriter
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text

    t0 = 1_700_000_000_000_000_000
    w = TrialWriter(path)
    w.start(metadata={}, calibration_toml=rig_to_toml_text(rig), time_ns=t0)
    gone = np.zeros(kp.shape[:2], bool)
    gone[lost[0], lost[1]] = True
    for c, cam in enumerate(kp.camera_names):
        for t, fid in enumerate(kp.frame_ids):
            if gone[c, t]:
                continue
            seen = [np.nan_to_num(p).tolist() for p in kp.keypoints[c, t] if (np.nan_to_num(p[:, 2]) > 0).any()]
            ts = t0 + int(kp.timestamps_ns[c, t])
            msg = {"camera": cam, "frame_id": int(fid), "timestamp_ns": ts, "skeleton": kp.skeleton.name,
                   "people": seen}
            w.add_keypoints(cam, json.dumps(msg).encode(), timestamp_ns=ts, frame_id=int(fid))
    return w.finish({})


@pytest.mark.skipif(not POSE2SIM_TRIAL.is_dir(), reason="Pose2Sim demo recordings not installed (deploy/bootstrap.sh)")
def test_real_keypoints_from_the_recording_reader_and_two_importers_are_the_one_type_with_provenance(tmp_path):
    """Pose2Sim's demo keypoints through the Pose2Sim-folder importer, the NPZ importer (the same keypoints as a
    multi-person file) and the recording's reader (the same keypoints as the detector node sends them, one
    camera's frames 3..5 lost on the way): the one type each time, the same keypoints, and each camera frame's
    provenance (a lost frame is missing)."""
    from gaitcap.acquisition.writers import save_multi_npz

    folder = read_keypoints_input(POSE2SIM_TRIAL)
    rec = folder.recording
    npz = read_keypoints_input(save_multi_npz(rec, tmp_path / "k.npz"))
    recorded = read_keypoints_input(_as_trial_mcap(rec, folder.rig, tmp_path / "t.mcap", lost=(1, slice(3, 6))))
    for data in (folder, npz, recorded):
        got = data.recording
        assert type(got) is MultiViewKeypoints and got.skeleton == rec.skeleton, data.source
        assert got.camera_names == rec.camera_names and got.shape[1] == rec.shape[1] > 10, data.source
    assert (rec.provenance == LIVE).all() and (npz.recording.provenance == LIVE).all()
    np.testing.assert_array_equal(npz.recording.keypoints, rec.keypoints)
    got = recorded.recording
    want = np.full(rec.shape[:2], LIVE)
    want[1, 3:6] = MISSING
    assert got.provenance.tolist() == want.tolist() and recorded.rig.names == folder.rig.names
    assert got.frame_ids.tolist() == rec.frame_ids.tolist()
    np.testing.assert_allclose(got.times_s, rec.times_s, atol=1e-9)
    p = got.shape[2]
    assert p >= 1 and not (np.nan_to_num(rec.keypoints[:, :, p:, :, 2]) > 0).any()  # nobody left out
    seen = (want == LIVE)[..., None, None] & (np.nan_to_num(rec.keypoints[:, :, :p, :, 2]) > 0)  # (C, T, P, J)
    np.testing.assert_array_equal(got.keypoints[seen], rec.keypoints[:, :, :p][seen])
    assert np.isnan(got.keypoints[1, 3:6, :, :, 0]).all() and (got.keypoints[1, 3:6, ..., 2] == 0).all()
