"""One trial, one path: a trial recorded by the stack (real processes: simulated cameras, detector,
recorder, worker, API; Zenoh on loopback; SQLite) gives exactly the same results in the clinic (its
worker, into the catalog and the trial's files) and on a researcher's machine (``gaitcap process`` on the
same recording, a separate process): gait parameters, events, warnings, the data-quality block, the
trajectories and the joint kinematics, stage by stage."""

import json
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.installed import share_path
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.ops.faults import Drill
from gaitcap.services.ops.stack import Stack, StackConfig

STAGES = ("preliminary", "refined")
RECORD_S = 14.0


@pytest.fixture(scope="module")
def both(tmp_path_factory):
    """(the clinic's trial folder, its REST view, ``gaitcap process``'s output folder and its --json)."""
    base = free_loopback_ports(12)[0]
    root = tmp_path_factory.mktemp("one-path")
    cfg = StackConfig(data_dir=root / "clinic", token="one-path-password-42", port=base, bus_base_port=base + 1,
                      cameras=6, size="160x120", fps=15.0, sim_seconds=60.0, lease_s=10.0, refine=True)
    with Stack(cfg) as stack:
        drill = Drill(stack, timeout_s=300)
        try:
            tid = drill.start("P0001")
            time.sleep(RECORD_S)
            drill.client.post(f"/trials/{tid}/stop").raise_for_status()
            drill.wait(lambda: drill.trial(tid)["state"] in ("done", "done_with_warnings"), f"trial {tid} done", 300)
            clinic = {"trial": drill.trial(tid),
                      "gait": {s: drill.client.get(f"/trials/{tid}/gait", params={"stage": s}).json() for s in STAGES}}
        finally:
            drill.close()
    folder = cfg.data_dir / "trials" / tid
    out = root / "offline"
    gaitcap = Path(sys.executable).with_name("gaitcap")  # the installed command, as a researcher runs it
    run = subprocess.run([str(gaitcap), "process", str(folder / "recording.mcap"),
                          "--out", str(out), "--json"], capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr[-3000:]
    return folder, clinic, out, json.loads(run.stdout.strip().splitlines()[-1])


def _json(path: Path) -> dict:
    return json.loads(path.read_text())


@pytest.mark.parametrize("stage", STAGES)
def test_every_stage_file_is_the_same_in_the_clinic_and_offline(both, stage):
    folder, _, out, _ = both
    names = {p.name for p in (folder / stage).iterdir()}
    assert names == {p.name for p in (out / stage).iterdir()}  # the same files
    if "gait.json" not in names:  # this stage found no steps in the clinic either
        return
    clinic, offline = _json(folder / stage / "gait.json"), _json(out / stage / "gait.json")
    assert clinic["data_quality"]["cameras"], clinic["data_quality"]  # the quality block is there to compare
    assert offline == clinic  # steps, events, summary, warnings, data-quality block, consistency rules
    for name in ("steps.csv", "summary.csv"):
        assert (out / stage / name).read_text() == (folder / stage / name).read_text(), name
    with np.load(folder / stage / "trajectory.npz") as a, np.load(out / stage / "trajectory.npz") as b:
        assert sorted(a.files) == sorted(b.files)
        for key in a.files:
            np.testing.assert_array_equal(a[key], b[key], err_msg=key)


def test_the_trials_checks_are_the_same_in_the_clinic_and_offline(both):
    folder, _, out, summary = both
    clinic = _json(folder / "checks.json")
    assert set(clinic) == {"one_person", "rig", "steps"} and _json(out / "checks.json") == clinic
    assert summary["data_quality"]["checks"] == clinic


def test_the_kinematics_are_the_same_in_the_clinic_and_offline(both):
    folder, _, out, _ = both
    clinic, offline = (_json(f / "refined" / "kinematics" / "kinematics.json") for f in (folder, out))
    for k in (clinic, offline):  # how long the model fit took (s) is the machine's, not the result's
        k.get("model", {}).pop("seconds", None)
    assert offline == clinic
    if clinic.get("available"):
        csv = Path("refined") / "kinematics" / "kinematics.csv"
        assert (out / csv).read_text() == (folder / csv).read_text()


def test_the_clinics_stored_numbers_are_the_files_numbers(both):
    folder, clinic, _, summary = both
    assert (folder / "refined" / "gait.json").is_file(), "the refined stage found no steps: nothing compared"
    for stage in (s for s in STAGES if (folder / s / "gait.json").is_file()):
        stored, written = clinic["gait"][stage], _json(folder / stage / "gait.json")
        assert len(stored["steps"]) == len(written["steps"]) > 0, stage
        assert [s["side"] for s in stored["steps"]] == [s["foot"] for s in written["steps"]], stage
        assert stored["data_quality"] == written["data_quality"], stage
    # what gaitcap process says of the data is what the clinic says (the quality block with the trial's checks,
    # its warnings)
    assert {**_json(folder / "refined" / "gait.json")["data_quality"], "checks": {}} == {**summary["data_quality"],
                                                                                       "checks": {}}
    assert set(summary["skipped"]) == {"completion"}  # every other step ran, as in the clinic's stack (no completion)
    for warning in summary["data_quality"]["warnings"]:
        assert warning in clinic["trial"]["warnings"], (warning, clinic["trial"]["warnings"])


POSE2SIM_TRIAL = share_path("testdata", "pose2sim", "S00_Demo_BatchSession", "S00_P00_SingleParticipant",
                            "S00_P00_T01_BalancingTrial")


@pytest.mark.skipif(not POSE2SIM_TRIAL.is_dir(), reason="Pose2Sim demo recordings not installed (deploy/bootstrap.sh)")
def test_the_same_real_keypoints_read_by_two_importers_give_the_same_files(tmp_path):
    """Real keypoints (Pose2Sim's demo trial: OpenPose JSON per camera, Pose2Sim's calibration) through
    ``gaitcap process`` as the Pose2Sim folder and as the NPZ keypoint file holding the same keypoints: the
    importers give the one keypoints type, so every file of every stage is the same."""
    from gaitcap.acquisition.writers import save_multi_npz, save_rig
    from gaitcap.services.processing.offline import OfflineOptions, load_input

    data = load_input(POSE2SIM_TRIAL, calibration=None, options=OfflineOptions())
    save_multi_npz(data.keypoints.recording, tmp_path / "keypoints.npz")
    save_rig(data.rig, tmp_path / "calibration.toml")
    gaitcap = Path(sys.executable).with_name("gaitcap")
    runs = {"folder": [str(POSE2SIM_TRIAL)],
            "npz": [str(tmp_path / "keypoints.npz"), "--calibration", str(tmp_path / "calibration.toml")]}
    for name, args in runs.items():
        run = subprocess.run([str(gaitcap), "process", *args, "--out", str(tmp_path / name), "--no-kinematics",
                              "--no-refine"],  # the stages after the first take what it takes: one is enough
                             capture_output=True, text=True, timeout=600)
        assert run.returncode == 0, (name, run.stderr[-3000:])
    for stage in ("preliminary",):
        a, b = tmp_path / "folder" / stage, tmp_path / "npz" / stage
        assert sorted(p.name for p in a.iterdir()) == sorted(p.name for p in b.iterdir()), stage
        with np.load(a / "trajectory.npz") as x, np.load(b / "trajectory.npz") as y:
            assert np.isfinite(x["points_mm"]).any()
            for key in x.files:
                np.testing.assert_array_equal(x[key], y[key], err_msg=f"{stage} {key}")
        if (a / "gait.json").is_file():
            assert _json(a / "gait.json") == _json(b / "gait.json"), stage
