"""Uploading a calibration: validated, stored, handed to the recorder with the next trial."""

from gaitcap.acquisition.writers import save_rig
from gaitcap.services.live.protocols import CameraHealth
from gaitcap.services.processing.pipeline import ring_rig


def test_uploaded_calibration_goes_to_the_next_trial(server, tmp_path):
    _, client, link, _ = server
    link.camera_list = [CameraHealth(f"cam{i}", 30.0, True, "ok", 0.01) for i in range(3)]
    save_rig(ring_rig(3), tmp_path / "rig.toml")
    toml = (tmp_path / "rig.toml").read_text()
    r = client.post("/calibrations", json={"toml": toml, "source": "board session 1"})
    assert r.status_code == 201 and r.json()["cameras"] == ["cam0", "cam1", "cam2"]
    assert client.get("/calibrations/latest").json()["id"] == r.json()["id"]
    client.post("/trials", json={"subject_id": "P9"})
    meta = link.calls[-1][3]
    assert meta["calibration_id"] == r.json()["id"] and "calibration_toml" not in meta
    assert link.calibration_toml == toml  # its own field


def test_a_bad_calibration_is_refused_naming_the_field(server):
    _, client, _, _ = server
    assert client.get("/calibrations/latest").status_code == 404
    r = client.post("/calibrations", json={"toml": "[cam_0]\nname = 'a'\n"})
    assert r.status_code == 422 and r.json()["detail"].startswith("toml:")
    assert client.post("/calibrations", json={"toml": ""}).json()["detail"].startswith("toml:")
