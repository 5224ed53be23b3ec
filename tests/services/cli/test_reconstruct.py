import json

import numpy as np
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.services.cli import app
from typer.testing import CliRunner


def _scene(cameras=4, frames=30):
    cams = []
    for i in range(cameras):
        a = 2 * np.pi * i / cameras
        c = np.array([4000 * np.cos(a), 4000 * np.sin(a), 1500.0])
        z = -c / np.linalg.norm(c)
        x = np.cross(z, [0, 0, 1.0])
        x /= np.linalg.norm(x)
        rot = np.stack([x, np.cross(z, x), z])
        k = np.array([[1000.0, 0, 640], [0, 1000.0, 400], [0, 0, 1]])
        cams.append(Camera(f"cam{i}", (1280, 800), k, np.zeros(5), matrix_to_rodrigues(rot), -rot @ c))
    rig = Rig(tuple(cams))
    rng = np.random.default_rng(0)
    gt = rng.normal(0, 250, (1, 26, 3)) + np.linspace([0, 0, 0], [300, 100, 0], frames)[:, None]
    kp = np.concatenate([rig.project(gt) + rng.normal(0, 1, (cameras, frames, 26, 2)),
                         np.full((cameras, frames, 26, 1), 0.9)], -1)
    return rig, MultiViewKeypoints.of_one_person(kp, rig.names, np.arange(frames) / 30, "halpe26"), gt


def test_reconstruct_command(tmp_path):
    rig, det, gt = _scene()
    save_rig(rig, tmp_path / "calib.json")
    np.savez(tmp_path / "kp.npz", keypoints=det.one_person, cameras=np.array(det.camera_names),
             times_s=det.times_s, skeleton=np.array("halpe26"))
    runner = CliRunner()
    args = ["reconstruct", "--calibration", str(tmp_path / "calib.json"), "--keypoints", str(tmp_path / "kp.npz"),
            "--method", "robust", "--out", str(tmp_path / "out.npz"), "--trc", str(tmp_path / "out.trc"), "--json"]
    res = runner.invoke(app, args)
    assert res.exit_code == 0, res.output
    metrics = json.loads(res.stdout.strip().splitlines()[-1])
    assert metrics["method"] == "robust" and metrics["GC_20"] > 0.9
    assert "NaN" not in res.stdout
    with np.load(tmp_path / "out.npz") as out:
        assert out["points_mm"].shape == gt.shape and list(out["joint_names"])[0] == "nose"
        assert str(out["method"]) == "robust" and list(out["camera_names"]) == list(det.camera_names)
        assert out["num_views"].shape == gt.shape[:2] and "dense_points_mm" not in out.files  # not a fit
        assert np.nanmean(np.linalg.norm(out["points_mm"] - gt, axis=-1)) < 10
    assert (tmp_path / "out.trc").read_text().startswith("PathFileType")
    bad = runner.invoke(app, args[:-1] + ["--paper"])
    assert bad.exit_code == 2 and "paper" in bad.output
    missing = runner.invoke(app, ["reconstruct", "--calibration", str(tmp_path / "calib.json"), "--keypoints",
                                  str(tmp_path / "nope.npz"), "--out", str(tmp_path / "o.npz")])
    assert missing.exit_code == 2 and "nope.npz" in missing.output
