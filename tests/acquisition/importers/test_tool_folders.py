"""Other tools' folders, written here in the formats those tools document, read back as keypoint inputs."""

import csv
import json
import tomllib

import numpy as np
import pytest
import tomli_w
from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
from gaitcap.reconstruction.calibration_io import rig_to_toml_text
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.reconstruction.skeletons import get_skeleton


def _rig(names) -> Rig:
    cams = []
    for i, name in enumerate(names):
        a = 2 * np.pi * i / len(names)
        c = np.array([3000 * np.cos(a), 3000 * np.sin(a), 1500.0])
        z = -c / np.linalg.norm(c)
        x = np.cross(z, [0, 0, 1.0])
        x /= np.linalg.norm(x)
        rot = np.stack([x, np.cross(z, x), z])
        cams.append(Camera(name, (640, 480), np.array([[600.0, 0, 320], [0, 600, 240], [0, 0, 1]]), np.zeros(5),
                           matrix_to_rodrigues(rot), -rot @ c))
    return Rig(tuple(cams))


def _toml_in_mm(rig: Rig) -> str:
    """aniposelib calibrated with a board measured in mm: translations in mm."""
    data = tomllib.loads(rig_to_toml_text(rig))
    for section in data.values():
        if isinstance(section, dict) and "translation" in section:
            section["translation"] = [1000 * v for v in section["translation"]]
    return tomli_w.dumps(data)


def _keypoints(c, t, j, seed=0):
    rng = np.random.default_rng(seed)
    kp = np.concatenate([rng.uniform(50, 600, (c, t, j, 2)), rng.uniform(0.2, 1.0, (c, t, j, 1))], -1)
    return np.round(kp, 3)


def _openpose_style(name: str) -> str:
    """left_big_toe -> LBigToe (the OpenPose / DeepLabCut naming used in anipose projects)."""
    side = {"left_": "L", "right_": "R"}
    prefix = next((v for k, v in side.items() if name.startswith(k)), "")
    rest = name.split("_", 1)[1] if prefix else name
    return prefix + "".join(p.capitalize() for p in rest.split("_"))


def test_anipose_folder_dlc_csv_mm_calibration(tmp_path):
    rig = _rig(["A", "B", "C"])
    (tmp_path / "calibration").mkdir()
    (tmp_path / "calibration" / "calibration.toml").write_text(_toml_in_mm(rig))
    skel = get_skeleton("halpe26")
    kp = _keypoints(3, 5, 26)
    order = np.random.default_rng(1).permutation(26)  # body parts in any column order
    (tmp_path / "pose-2d").mkdir()
    for c, cam in enumerate(["C", "A", "B"]):  # files listed in another order than the calibration
        with open(tmp_path / "pose-2d" / f"walk-cam{cam}.csv", "w", newline="") as f:
            w = csv.writer(f)
            parts = [_openpose_style(skel.joint_names[j]) for j in order]
            w.writerow(["scorer"] + ["DLC_resnet50"] * 78)
            w.writerow(["bodyparts"] + [p for p in parts for _ in range(3)])
            w.writerow(["coords"] + ["x", "y", "likelihood"] * 26)
            for t in range(5):
                w.writerow([t] + [f"{v:.3f}" for j in order for v in kp[c, t, j]])
    data = read_keypoints_input(tmp_path)
    assert data.source == "anipose folder" and data.layout == "halpe26"
    assert data.recording.camera_names == ("A", "B", "C")  # by the name at the end of each file's name
    np.testing.assert_allclose(data.recording.keypoints[:, :, 0], kp[[1, 2, 0]], atol=1e-9)
    for cam in rig.cameras:  # the mm translations were recognised as mm
        np.testing.assert_allclose(data.rig.cameras[data.rig.names.index(cam.name)].tvec_mm, cam.tvec_mm, atol=1e-6)


def test_freemocap_recording_folder(tmp_path):
    rig = _rig(["cam_0", "cam_1"])
    (tmp_path / "rec_camera_calibration.toml").write_text(_toml_in_mm(rig))
    raw = tmp_path / "output_data" / "raw_data"
    raw.mkdir(parents=True)
    xy = _keypoints(2, 6, 543)[..., :2]  # body 33 + hands 42 + face 468
    xy[1, 2, 5] = np.nan  # not seen
    np.save(raw / "mediapipe_2dData_numCams_numFrames_numTrackedPoints_pixelXY.npy", xy)
    data = read_keypoints_input(tmp_path)
    assert data.layout == "mediapipe33" and data.recording.keypoints.shape == (2, 6, 1, 33, 3)
    people = data.recording.keypoints[:, :, 0]
    np.testing.assert_allclose(people[..., :2], xy[:, :, :33])
    assert people[1, 2, 5, 2] == 0 and people[0, 0, 0, 2] == 1
    np.testing.assert_allclose(data.rig.cameras[1].tvec_mm, rig.cameras[1].tvec_mm, atol=1e-6)


def _mmpose_instances(kp_frame):
    return [{"keypoints": p[:, :2].tolist(), "keypoint_scores": p[:, 2].tolist(), "bbox": [[0, 0, 10, 10]],
             "bbox_score": 0.9} for p in kp_frame]


def test_mmpose_json_both_layouts(tmp_path):
    kp = _keypoints(2, 4, 17)
    people = np.stack([kp, kp * [1, 1, 0.5]], axis=2)  # (C, T, 2, 17, 3): a second, fainter person
    demo = tmp_path / "demo"
    demo.mkdir()
    for c, cam in enumerate(["cam1", "cam0"]):
        doc = {"meta_info": {"dataset_name": "coco", "num_keypoints": 17},
               "instance_info": [{"frame_id": t + 1, "instances": _mmpose_instances(people[c, t, ::-1])}
                                 for t in range(4)]}
        (demo / f"results_{cam}.json").write_text(json.dumps(doc))
    data = read_keypoints_input(demo, rig=_rig(["cam0", "cam1"]), fps=25)
    assert data.layout == "coco17" and "coco" in data.source
    assert data.recording.camera_names == ("cam0", "cam1")  # results_cam0.json holds camera 1 of the array
    np.testing.assert_allclose(data.recording.keypoints, people[[1, 0]], atol=1e-9)  # most confident first again
    assert data.recording.times_s[1] == pytest.approx(1 / 25)
    frames = [[{"keypoints": p[:, :2].tolist(), "keypoint_scores": p[:, 2].tolist()} for p in people[0, t]]
              for t in range(4)]
    (tmp_path / "inferencer.json").write_text(json.dumps(frames))
    single = read_keypoints_input(tmp_path / "inferencer.json")
    assert single.layout is None and single.recording.skeleton.name == "coco17"  # no dataset name: recognised later
    np.testing.assert_allclose(single.recording.keypoints[0], people[0], atol=1e-9)
    (tmp_path / "bad.json").write_text(json.dumps([[{"keypoints": [[1, 2]], "keypoint_scores": [0.5, 0.4]}]]))
    with pytest.raises(ValueError, match="1 keypoints but 2 keypoint_scores"):
        read_keypoints_input(tmp_path / "bad.json")


def test_pose2sim_folder_config_inherited_and_unknown_model(tmp_path):
    session = tmp_path / "session"
    trial = session / "P1" / "T1"
    (trial / "pose" / "cam01_json").mkdir(parents=True)
    (session / "calibration").mkdir(parents=True)
    (session / "calibration" / "Calib_board.toml").write_text(rig_to_toml_text(_rig(["cam01", "cam02"])))
    (session / "Config.toml").write_text('[project]\nframe_rate = 50\n[pose]\npose_model = "HALPE_26"\n')
    (trial / "Config.toml").write_text("[project]\nmulti_person = true\n")  # inherits the session's
    kp = _keypoints(1, 3, 26)
    for t in range(3):
        doc = {"people": [{"pose_keypoints_2d": kp[0, t].reshape(-1).tolist()}]}
        (trial / "pose" / "cam01_json" / f"cam01.{t:04d}.json").write_text(json.dumps(doc))
    (trial / "pose" / "cam02_json").mkdir()
    (trial / "pose" / "cam02_json" / "cam02.0000.json").write_text(json.dumps({"people": []}))
    data = read_keypoints_input(trial)
    assert data.layout == "halpe26" and data.recording.times_s[1] == pytest.approx(1 / 50)
    assert data.recording.camera_names == ("cam01", "cam02") and list(data.rig.names) == ["cam01", "cam02"]
    assert (data.recording.keypoints[1, ..., 2] == 0).all()  # cam02 saw nobody
    (session / "Config.toml").write_text('[pose]\npose_model = "ANIMAL2D_17"\n')
    with pytest.raises(ValueError, match="pose_model 'ANIMAL2D_17' is not supported"):
        read_keypoints_input(trial)


def test_anipose_folder_with_the_deeplabcut_h5_files_anipose_writes(tmp_path):
    pd = pytest.importorskip("pandas", reason="the anipose extra (pandas, PyTables) is part of the dev install")
    rig = _rig(["A", "B"])
    (tmp_path / "calibration.toml").write_text(_toml_in_mm(rig))
    (tmp_path / "pose-2d").mkdir()
    skel = get_skeleton("halpe26")
    kp = _keypoints(2, 6, 26, seed=3)
    parts = [_openpose_style(n) for n in skel.joint_names]
    for c, cam in enumerate(["A", "B"]):  # as DeepLabCut saves: df.to_hdf(..., "df_with_missing", format="table")
        cols = pd.MultiIndex.from_product([["DLC_resnet50"], parts, ["x", "y", "likelihood"]],
                                          names=["scorer", "bodyparts", "coords"])
        pd.DataFrame(kp[c].reshape(6, -1), columns=cols).to_hdf(tmp_path / "pose-2d" / f"walk-cam{cam}.h5",
                                                               key="df_with_missing", format="table", mode="w")
    data = read_keypoints_input(tmp_path)
    assert data.source == "anipose folder" and data.layout == "halpe26"
    np.testing.assert_allclose(data.recording.keypoints[:, :, 0], kp, atol=1e-9)
    (tmp_path / "pose-2d" / "walk-camB.h5").write_bytes(b"not hdf5")
    with pytest.raises(ValueError, match="walk-camB.h5: not a readable DeepLabCut .h5"):
        read_keypoints_input(tmp_path)
