import numpy as np
import pytest
from gaitcap.acquisition.writers import save_detections_npz, save_multi_npz
from gaitcap.reconstruction.association.npz_io import load_detections_npz, load_multi_npz
from gaitcap.reconstruction.detections import Detections


def test_multi_and_single_round_trip(tmp_path, scene3):
    path = tmp_path / "multi.npz"
    save_multi_npz(scene3.multi, path)
    back = load_multi_npz(path)
    np.testing.assert_array_equal(back.keypoints, scene3.multi.keypoints)
    assert back.camera_names == scene3.multi.camera_names and back.skeleton.name == "halpe26"
    det = Detections(scene3.multi.keypoints[:, :, 0], scene3.multi.camera_names, scene3.multi.times_s,
                     "halpe26")
    save_detections_npz(det, tmp_path / "one.npz", track_id=3)
    one = load_detections_npz(tmp_path / "one.npz")
    np.testing.assert_array_equal(one.keypoints, det.keypoints)
    assert int(np.load(tmp_path / "one.npz")["track_id"]) == 3
    assert load_multi_npz(tmp_path / "one.npz").shape[2] == 1  # one person per slot is fine
    assert [p.name for p in tmp_path.iterdir() if p.name.startswith(".")] == []


def test_missing_file_and_missing_arrays_are_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nope.npz"):
        load_multi_npz(tmp_path / "nope.npz")
    np.savez(tmp_path / "bad.npz", keypoints=np.zeros((1, 2, 1, 26, 3)))
    with pytest.raises(ValueError, match="missing arrays \\['camera_names', 'times_s', 'skeleton'\\]"):
        load_multi_npz(tmp_path / "bad.npz")
