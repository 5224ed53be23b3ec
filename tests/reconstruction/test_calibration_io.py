import json

import numpy as np
import pytest
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.calibration_io import rig_from_toml_text
from gaitcap.reconstruction.camera import Camera, Rig


def _rig() -> Rig:
    rng = np.random.default_rng(1)
    cams = []
    for i in range(3):
        k = np.array([[1400.0 + i, 0, 960], [0, 1400.0, 600], [0, 0, 1]])
        cams.append(Camera(f"cam{i}", (1920, 1200), k, [-0.1 * i, 0, 0, 0, 0], rng.normal(size=3), rng.normal(size=3) * 1000, serial=f"2{i}"))
    return Rig(tuple(cams))


@pytest.mark.parametrize("suffix", [".toml", ".json"])
def test_round_trip(tmp_path, suffix):
    rig = _rig()
    back = load_rig(save_rig(rig, tmp_path / f"calib{suffix}"))
    assert back.names == rig.names
    for a, b in zip(rig, back, strict=True):
        assert a.size_px == b.size_px and a.serial == b.serial
        for f in ("matrix_px", "dist", "rvec", "tvec_mm"):
            assert np.allclose(getattr(a, f), getattr(b, f), atol=1e-9), f


def test_toml_translation_is_in_metres(tmp_path):
    path = save_rig(_rig(), tmp_path / "c.toml")
    text = path.read_text()
    t_m = _rig()[0].tvec_mm / 1000
    assert f"{t_m[0]}" in text or f"{t_m[0]:.6f}"[:6] in text


def test_reads_pose2sim_style_toml_with_4_distortions_and_matrix_rotation():
    text = """
[cam_1]
name = "cam01"
size = [ 1920.0, 1080.0,]
matrix = [ [ 1500.0, 0.0, 960.0,], [ 0.0, 1500.0, 540.0,], [ 0.0, 0.0, 1.0,],]
distortions = [ -0.05, 0.01, 0.0, 0.0,]
rotation = [ [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0] ]
translation = [ 0.5, 1.2, 3.0,]
fisheye = false

[metadata]
adjusted = false
error = 0.0
"""
    rig = rig_from_toml_text(text)
    cam = rig["cam01"]
    assert np.allclose(cam.tvec_mm, [500, 1200, 3000])
    assert np.allclose(cam.dist, [-0.05, 0.01, 0, 0, 0])
    assert np.allclose(cam.rotation, [[1, 0, 0], [0, 0, -1], [0, 1, 0]], atol=1e-9)


@pytest.mark.parametrize(
    ("mutate", "message"),
    [
        (lambda s: s.replace('name = "cam01"\n', ""), r"\[cam_1\]: missing field 'name'"),
        (lambda s: s.replace("[ 0.5, 1.2, 3.0,]", "[0.5, 1.2]"), r"\[cam_1\]: field 'translation' has shape"),
        (lambda s: s.replace("[0.0, 0.0, -1.0]", "[0.0, 0.5, -1.0]"), "not orthonormal"),
        (lambda s: s.replace("size = [ 1920.0, 1080.0,]", "size = [1920.0]"), "field 'size'"),
    ],
)
def test_bad_toml_names_section_and_field(mutate, message):
    text = """
[cam_1]
name = "cam01"
size = [ 1920.0, 1080.0,]
matrix = [ [ 1500.0, 0.0, 960.0,], [ 0.0, 1500.0, 540.0,], [ 0.0, 0.0, 1.0,],]
distortions = [ -0.05, 0.0, 0.0, 0.0,]
rotation = [ [1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0] ]
translation = [ 0.5, 1.2, 3.0,]
"""
    with pytest.raises(ValueError, match=message):
        rig_from_toml_text(mutate(text))


def test_bad_json_and_missing_file(tmp_path):
    with pytest.raises(ValueError, match="does not exist"):
        load_rig(tmp_path / "nope.toml")
    p = tmp_path / "c.json"
    data = json.loads(json.dumps({"format": "gaitcap-calibration", "version": 1, "cameras": [{"name": "a"}]}))
    p.write_text(json.dumps(data))
    with pytest.raises(ValueError, match=r"cameras\[0\]: missing field 'size_px'"):
        load_rig(p)


def test_save_is_atomic_on_failure(tmp_path):
    path = save_rig(_rig(), tmp_path / "c.toml")
    before = path.read_text()
    with pytest.raises(ValueError):
        save_rig(_rig(), tmp_path / "c.yaml")
    assert path.read_text() == before
    assert not list(tmp_path.glob("*.tmp"))
