import importlib.util
import json
import sys
from pathlib import Path

import numpy as np
from gaitcap.services.cli import app
from typer.testing import CliRunner

# The gait tests' analytic walker (loaded under its own name: every test folder has a conftest).
_WALKER = Path(__file__).resolve().parents[2] / "reconstruction" / "gait" / "conftest.py"
_spec = importlib.util.spec_from_file_location("gait_test_walker", _WALKER)
_module = sys.modules.setdefault("gait_test_walker", importlib.util.module_from_spec(_spec))
_spec.loader.exec_module(_module)
make_walk = _module.make_walk


def test_gait_command_json_csv_plot(tmp_path):
    walk = make_walk(segments=(("line", 5000), ("arc", 500, 180), ("line", 5000)))
    npz = tmp_path / "trial.npz"
    np.savez(npz, points_mm=walk.points_mm, times_s=walk.times_s, joint_names=np.array(walk.joint_names))
    runner = CliRunner()
    res = runner.invoke(app, ["gait", str(npz), "--json", "--csv", str(tmp_path / "s.csv"),
                              "--plot", str(tmp_path / "p.png")])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout.strip().splitlines()[-1])
    assert len(report["steps"]) >= 8 and report["summary"]["num_passes"] == 2
    assert abs(report["steps"][0]["step_length_mm"] - 650.0) < 1.0
    assert (tmp_path / "s.csv").read_text().count("\n") == len(report["steps"]) + 1
    assert (tmp_path / "p.png").read_bytes()[:4] == b"\x89PNG"
    text = runner.invoke(app, ["gait", str(npz)])
    assert text.exit_code == 0 and "cadence" in text.stdout
    # frames only (no dense trajectory in the file): the events say they are located to one frame
    assert "events located on the spline through frames: resolution 33 ms (one frame" in text.stdout
    assert report["timing"]["located_on"] == "spline through frames"


def test_gait_command_bad_input(tmp_path):
    npz = tmp_path / "bad.npz"
    np.savez(npz, points_mm=np.zeros((10, 3, 3)))
    res = CliRunner().invoke(app, ["gait", str(npz)])
    assert res.exit_code == 2 and "times_s" in res.output


def test_gait_command_with_walkway(tmp_path):
    from gaitcap.acquisition.writers import write_walkway_csv
    from gaitcap.reconstruction.gait.walkway import Similarity2D, WalkwayTrial

    walk = make_walk(segments=(("line", 5000), ("arc", 500, 180), ("line", 3200)))
    npz = tmp_path / "t1.npz"
    views = np.full(walk.points_mm.shape[:2], 4.0)
    np.savez(npz, points_mm=walk.points_mm, times_s=walk.times_s, joint_names=np.array(walk.joint_names),
             num_views=views)
    first_leg = walk.arc_mm < 4500
    keep = np.isfinite(walk.hs_s) & np.isfinite(walk.to_s) & (first_leg | (walk.arc_mm > 7100))
    heading = np.where(first_leg[:, None], 1.0, -1.0) * [np.cos(np.radians(30)), np.sin(np.radians(30))]
    tf = Similarity2D(1.0, 0.5, (100.0, 200.0))
    toes = walk.heels_mm + 230.0 * heading
    trial = WalkwayTrial("t1", tuple(np.array(walk.feet)[keep]), walk.hs_s[keep] - 0.7, walk.to_s[keep] - 0.7,
                         tf.apply(walk.heels_mm[keep]), tf.apply(toes[keep]))
    csv_path = tmp_path / "walkway.csv"
    write_walkway_csv([trial], csv_path)
    res = CliRunner().invoke(app, ["gait", str(npz), "--walkway", str(csv_path), "--json"])
    assert res.exit_code == 0, res.output
    report = json.loads(res.stdout.strip().splitlines()[-1])
    assert abs(report["walkway"]["offsets_s"]["t1"] - 0.7) < 0.05
    assert report["walkway"]["residuals"]["heel_lateral_mm"]["n"] == int(keep.sum())


def _gait_json(npz: Path) -> dict:
    res = CliRunner().invoke(app, ["gait", str(npz), "--json"])
    assert res.exit_code == 0, res.output
    return json.loads(res.stdout.strip().splitlines()[-1])


def test_gait_reads_an_older_worker_trajectory_npz(tmp_path):
    """The worker's file before method, cameras and dense samples (a fit's num_views empty)."""
    from gaitcap.services.processing.outputs import read_npz

    walk = make_walk(segments=(("line", 5000),))
    npz = tmp_path / "trajectory.npz"
    np.savez(npz, points_mm=walk.points_mm, times_s=walk.times_s, joint_names=np.array(walk.joint_names),
             num_views=np.zeros(0))
    traj, reproj = read_npz(npz)
    assert traj.quality is None and traj.trajectory is None and reproj is None
    assert traj.method == "trajectory.npz" and traj.camera_names == ()
    report = _gait_json(npz)
    assert len(report["steps"]) >= 5 and abs(report["steps"][0]["step_length_mm"] - 650.0) < 1.0


def test_gait_reads_an_older_reconstruct_npz(tmp_path):
    """``gaitcap reconstruct``'s former file: ``quality`` (agreeing views), camera weights, method."""
    from gaitcap.services.processing.outputs import read_npz

    walk = make_walk(segments=(("line", 5000),))
    t, j = walk.points_mm.shape[:2]
    npz = tmp_path / "old.npz"
    np.savez(npz, points_mm=walk.points_mm, times_s=walk.times_s, joint_names=np.array(walk.joint_names),
             camera_names=np.array(["cam0", "cam1", "cam2"]), camera_weights=np.ones((3, t, j)),
             quality=np.full((t, j), 3.0), method=np.array("robust"))
    traj, _ = read_npz(npz)
    assert traj.method == "robust" and traj.camera_names == ("cam0", "cam1", "cam2") and traj.trajectory is None
    assert traj.quality.shape == (t, j) and np.all(traj.quality == 3.0)
    report = _gait_json(npz)
    assert len(report["steps"]) >= 5 and abs(report["steps"][0]["step_length_mm"] - 650.0) < 1.0
