"""The readers of what ``reconstruction/`` parses: keypoint NPZ files, calibrations, walkway exports;
every error names the file."""

import json

import numpy as np
import pytest
from gaitcap.acquisition.readers import (
    load_detections_npz,
    load_multi_npz,
    load_rig,
    read_keypoint_arrays,
    read_walkway_csv,
)
from gaitcap.acquisition.writers import save_detections_npz, save_multi_npz, save_rig
from gaitcap.reconstruction.camera import Camera, Rig
from gaitcap.reconstruction.keypoints import COMPLETED, LIVE, MISSING, MultiViewKeypoints


def _multi() -> MultiViewKeypoints:
    """2 cameras, 5 frames (ids 100..104), 3 people, halpe26; one empty slot (NaN); cam_b's frame 101 missing,
    its frame 103 completed after Stop."""
    rng = np.random.default_rng(3)
    kp = np.concatenate([rng.uniform(0, 1000, (2, 5, 3, 26, 2)), rng.uniform(0.2, 1, (2, 5, 3, 26, 1))], -1)
    kp[1, 2, 2] = np.nan
    stamps = np.tile(np.arange(5) * 33_333_333 + 7, (2, 1))
    stamps[1, 1] = -1
    provenance = np.where(stamps >= 0, LIVE, MISSING)
    provenance[1, 3] = COMPLETED
    return MultiViewKeypoints(kp, ("cam_a", "cam_b"), np.arange(5) / 30, "halpe26", frame_ids=np.arange(100, 105),
                              timestamps_ns=stamps, provenance=provenance)


def test_multi_and_single_round_trip(tmp_path):
    multi = _multi()
    path = tmp_path / "multi.npz"
    save_multi_npz(multi, path)
    back = load_multi_npz(path)
    np.testing.assert_array_equal(back.keypoints, multi.keypoints)
    np.testing.assert_array_equal(back.times_s, multi.times_s)
    assert back.camera_names == multi.camera_names and back.skeleton.name == "halpe26"
    for fact in ("frame_ids", "timestamps_ns", "provenance"):  # where the keypoints came from, kept
        np.testing.assert_array_equal(getattr(back, fact), getattr(multi, fact), err_msg=fact)
    det = multi.patient()
    save_detections_npz(det, tmp_path / "one.npz", track_id=3)
    one = load_detections_npz(tmp_path / "one.npz")
    np.testing.assert_array_equal(one.keypoints, det.keypoints)
    assert int(np.load(tmp_path / "one.npz")["track_id"]) == 3
    assert load_multi_npz(tmp_path / "one.npz").shape == (2, 5, 1, 26)  # one person per slot is fine
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_missing_file_missing_arrays_and_bad_arrays_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.npz"):
        load_multi_npz(tmp_path / "nope.npz")
    np.savez(tmp_path / "bad.npz", keypoints=np.zeros((1, 2, 1, 26, 3)))
    with pytest.raises(ValueError, match="bad.npz: missing arrays \\['camera_names', 'times_s', 'skeleton'\\]"):
        load_multi_npz(tmp_path / "bad.npz")
    np.savez(tmp_path / "short.npz", keypoints=np.zeros((2, 3, 26, 3)), camera_names=np.array(["a", "b"]),
             times_s=np.arange(4) / 30, skeleton=np.array("halpe26"))
    with pytest.raises(ValueError, match="short.npz: times_s: expected 3 times"):
        load_detections_npz(tmp_path / "short.npz")
    np.savez(tmp_path / "tool.npz", keypoints=np.zeros((2, 3, 26, 3)), cameras=np.array(["a", "b"]))
    with pytest.raises(ValueError, match="tool.npz: missing arrays \\['times_s', 'skeleton'\\]"):
        load_detections_npz(tmp_path / "tool.npz")  # camera names under 'cameras' are read
    np.savez(tmp_path / "nonames.npz", keypoints=np.zeros((2, 3, 26, 3)))
    with pytest.raises(ValueError, match="nonames.npz: missing arrays \\['camera_names'\\] .*'cameras'"):
        read_keypoint_arrays(tmp_path / "nonames.npz", optional=("times_s", "skeleton"))
    inf = np.zeros((2, 3, 26, 3))
    inf[1, 2, 0, 0] = np.inf
    np.savez(tmp_path / "inf.npz", keypoints=inf, camera_names=np.array(["a", "b"]), times_s=np.arange(3) / 30,
             skeleton=np.array("halpe26"))
    with pytest.raises(ValueError, match="inf.npz: keypoints of camera 'b' are infinite"):
        load_detections_npz(tmp_path / "inf.npz")
    np.savez(tmp_path / "prov.npz", keypoints=np.zeros((2, 3, 26, 3)), camera_names=np.array(["a", "b"]),
             times_s=np.arange(3) / 30, skeleton=np.array("halpe26"), provenance=np.full((2, 3), 9))
    with pytest.raises(ValueError, match=r"prov.npz: provenance: .* with \[9\]"):
        load_multi_npz(tmp_path / "prov.npz")


def test_calibration_read_back_and_bad_files_named(tmp_path):
    cam = Camera(name="c0", size_px=(640, 480), matrix_px=np.array([[500.0, 0, 320], [0, 500, 240], [0, 0, 1]]),
                 dist=np.zeros(5), rvec=np.array([0.1, -0.2, 0.05]), tvec_mm=np.array([10.0, -20.0, 3000.0]))
    for suffix in (".toml", ".json"):
        back = load_rig(save_rig(Rig((cam,)), tmp_path / f"calib{suffix}"))
        assert back.names == ["c0"]
        np.testing.assert_allclose(back.cameras[0].tvec_mm, cam.tvec_mm, atol=1e-9)
    with pytest.raises(ValueError, match="nope.toml.*does not exist"):
        load_rig(tmp_path / "nope.toml")
    (tmp_path / "c.yaml").write_text("{}")
    with pytest.raises(ValueError, match="c.yaml: unknown calibration format '.yaml'"):
        load_rig(tmp_path / "c.yaml")
    (tmp_path / "broken.json").write_text("{not json")
    with pytest.raises(ValueError, match="broken.json: not valid JSON"):
        load_rig(tmp_path / "broken.json")
    (tmp_path / "fields.json").write_text(json.dumps({"format": "gaitcap-calibration", "version": 1,
                                                      "cameras": [{"name": "a"}]}))
    with pytest.raises(ValueError, match=r"fields.json.*cameras\[0\]: missing field 'size_px'"):
        load_rig(tmp_path / "fields.json")


def test_walkway_errors_name_the_file_and_line(tmp_path):
    path = tmp_path / "walk.csv"
    path.write_text("trial,foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm,toe_y_mm\n"
                    "a,L,1,1.6,0,70,200,70\n\na,R,1.5,x,650,-70,850,-70\n")
    with pytest.raises(ValueError, match=f"{path}:4: a time or position is not a number"):
        read_walkway_csv(path)
    with pytest.raises(FileNotFoundError, match="nope.csv"):
        read_walkway_csv(tmp_path / "nope.csv")
