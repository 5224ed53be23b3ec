"""``gaitcap associate`` on a synthetic three-person trial written to files."""

import numpy as np
import pytest
from gaitcap.acquisition.readers import load_detections_npz
from gaitcap.acquisition.writers import save_multi_npz, save_rig
from gaitcap.services.cli import app
from gaitcap.simulator import make_trial
from typer.testing import CliRunner


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    root = tmp_path_factory.mktemp("associate")
    trial = make_trial(preset="paper", seconds=5.0, cameras=6, people=3, seed=3)
    save_multi_npz(trial.multi.observed, root / "multi.npz")
    save_rig(trial.rig, root / "calib.toml")
    return root, trial


def _person_in(out, trial, person):
    """The output holds ``person``'s detections (those the association found mirrored swapped back)."""
    det = load_detections_npz(out)
    raw = trial.multi.person(person)
    truth = raw[..., 0]
    unmirrored = raw[:, :, list(trial.skeleton.flip_permutation), 0]
    mine = det.one_person[..., 0]
    both = np.isfinite(mine) & np.isfinite(truth)
    same = (mine == truth) | (mine == unmirrored)
    return both.sum() > 0.9 * np.isfinite(truth).sum() and bool(same[both].all())


def test_automatic_and_start_position_choices(files):
    root, trial = files
    runner = CliRunner()
    res = runner.invoke(app, ["associate", str(root / "multi.npz"), "-c", str(root / "calib.toml"),
                              "-o", str(root / "patient.npz")])
    assert res.exit_code == 0, res.output
    assert "chose track" in res.output and _person_in(root / "patient.npz", trial, 0)
    standing = trial.multi.points_mm[2, 0, trial.skeleton.index("pelvis")]
    res = runner.invoke(app, ["associate", str(root / "multi.npz"), "-c", str(root / "calib.toml"),
                              "-o", str(root / "bystander.npz"),
                              "--start", ",".join(f"{v:.0f}" for v in standing)])
    assert res.exit_code == 0, res.output
    assert _person_in(root / "bystander.npz", trial, 2)
    assert int(np.load(root / "bystander.npz")["track_id"]) >= 0


def test_bad_track_and_bad_options_exit_2_with_a_message(files):
    root, _ = files
    runner = CliRunner()
    base = ["associate", str(root / "multi.npz"), "-c", str(root / "calib.toml"), "-o", str(root / "x.npz")]
    res = runner.invoke(app, [*base, "--track", "42"])
    assert res.exit_code == 2 and "track id 42 does not exist" in res.output
    res = runner.invoke(app, [*base, "--start", "1,2"])
    assert res.exit_code == 2 and "--start" in res.output
    res = runner.invoke(app, [*base, "--track", "0", "--start", "0,0,0"])
    assert res.exit_code == 2 and "at most one" in res.output
    assert not (root / "x.npz").exists()
