"""The OpenSim model fit on the synthetic walker: accuracy against its true joint angles, the files
(MOT, OSIM, TRC, C3D read back), the sign conventions read off the model, and a clear error without it."""

import json
import os

import numpy as np
import pytest
from gaitcap.services.kinematics import KinematicsUnavailable, get_engine

opensim = pytest.importorskip("opensim", reason="the kinematics extra (opensim) is not installed")


@pytest.fixture(scope="module")
def engine():
    try:
        return get_engine()
    except KinematicsUnavailable as exc:
        pytest.skip(f"OpenSim setup files not installed: {exc}")


@pytest.fixture(scope="module")
def fitted(engine, tmp_path_factory):
    """8 s of the synthetic walker (exact keypoints), fitted once."""
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.services.kinematics.trial import trial_kinematics
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(), np.arange(240) / 30.0
    points = simulate_body(plan_walk(params, 8.0, Room(), seed=1), params, times)
    names = get_skeleton("halpe26").joint_names
    report = analyze_gait(points, times, list(names))
    out = tmp_path_factory.mktemp("kin")
    # a child of 9: the files carry the children's band (a patient without a recorded age gets none)
    kin = trial_kinematics(points, times, names, steps=report.steps, out_dir=out, age_years=9)
    return points, times, names, report, kin, out


def test_ik_matches_the_walkers_true_angles(engine, fitted):
    from gaitcap.reconstruction.kinematics.angles import clinical_angles
    from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
    from gaitcap.reconstruction.kinematics.mot import parse_mot
    from gaitcap.reconstruction.kinematics.report import with_zero_offsets

    points, times, names, _, kin, out = fitted
    truth = keypoint_angles(points, names)
    mot_times, coords, in_degrees = parse_mot((out / "kinematics.mot").read_text())
    assert in_degrees and np.allclose(mot_times, times, atol=1e-5)
    # the reported angles: the model's plus its zero pose measured like the keypoints
    ik = with_zero_offsets(clinical_angles(coords, mot_times), kin.model["angle_zero_offsets_deg"])
    errors = {}
    for var in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion", "hip_adduction"):
        for side in ("left", "right"):
            err = ik[var][side] - truth[var][side]
            errors[var, side] = float(np.sqrt(np.mean(err**2)))
    # measured on these 8 s (the walker standing upright, its knee to 64 deg in swing; the hip, knee and ankle
    # markers on the joint centres, the foot markers in the walker's foot shape, hinged knees): hip flexion
    # 0.11 / 0.10, knee 0.28 / 0.26, ankle 0.31 / 0.28, hip adduction 0.75 / 0.73 (left / right; with the
    # knee marker 10 mm above the knee's axis, Pose2Sim's, 0.16 / 0.16, 0.42 / 0.45, 0.48 / 0.55, 0.61 / 0.64).
    # With Pose2Sim's foot markers (the walker's heel lower and its ankle further forward than the model's)
    # knee 1.4 / 1.7 and ankle 3.4 / 3.0 had needed limits of 2.0 and 4.0; these are the limits the suite had
    # before.
    limits = {"hip_flexion": 2.5, "knee_flexion": 1.5, "ankle_dorsiflexion": 3.0, "hip_adduction": 2.5}
    for (var, side), rmse in errors.items():
        assert rmse < limits[var], (var, side, rmse)
    # the walker's pelvis is upright: the keypoints do not tilt the model's (measured mean 1.2 deg)
    assert abs(np.nanmean(ik["pelvis_tilt"]["left"])) < 2.5


def test_scaled_model_has_joint_markers_on_the_joint_centres_and_feet_in_the_keypoints_shape(engine, fitted):
    """The fitted model's hip, knee and ankle markers are its hip, knee and ankle joint centres (the
    keypoints' hips, knees and ankles; Pose2Sim's knee marker sat 10 mm above the knee's axis), and its heel
    and toe markers sit on the calcanei where the walker's foot puts them: in the zero pose the foot line is
    at right angles to the shank (knee to ankle joint centre), so the model's zero reads 0 deg of ankle
    dorsiflexion measured like the keypoints (it read -7 deg with Pose2Sim's foot markers, -0.7 with the
    shank drawn from the tibia's origin)."""
    out = fitted[-1]
    model = opensim.Model(str(out / "kinematics.osim"))
    model.initSystem()
    markers, joints = model.getMarkerSet(), model.getJointSet()
    for marker, joint in (("LHip", "hip_l"), ("RHip", "hip_r"), ("LKnee", "walker_knee_l"), ("RKnee", "walker_knee_r"),
                          ("LAnkle", "ankle_l"), ("RAnkle", "ankle_r")):
        centre = opensim.PhysicalOffsetFrame.safeDownCast(joints.get(joint).getParentFrame()).get_translation()
        assert np.allclose(markers.get(marker).get_location().to_numpy(), centre.to_numpy(), atol=1e-6), marker
    for side in "LR":
        for part in ("Heel", "BigToe", "SmallToe"):
            assert markers.get(side + part).getParentFrameName().endswith(f"calcn_{side.lower()}"), side + part
    d = json.loads((out / "kinematics.json").read_text())
    for side in ("left", "right"):
        assert abs(d["model"]["angle_zero_offsets_deg"]["ankle_dorsiflexion"][side]) < 1.5, side
    # at most the knees rest on a bound, their lower (0: the model's knee does not hyperextend) while the
    # walker stands with a straight leg (none measured since the knee markers are on the knees' axes); each
    # is a warning
    hits = d["model"]["coordinates_at_bounds"]
    assert {(h["coordinate"], h["bound"]) for h in hits} <= {("knee_angle_l", "lower"), ("knee_angle_r", "lower")}, hits
    assert len(d["warnings"]) == len(hits) and all("rests on its lower bound (0 deg)" in w for w in d["warnings"])


def test_report_files_and_exports(fitted):
    import ezc3d
    from gaitcap.services.kinematics.files import norms_file

    points, times, names, report, kin, out = fitted
    d = json.loads((out / "kinematics.json").read_text())
    assert d["available"] and d["model"]["frames_fitted"] == len(times)
    assert d["curves"]["knee_flexion"]["left"]["n_cycles"] >= 2
    assert 50 < d["key_values"]["right"]["knee_peak_flexion_swing_deg"]["mean"] < 75
    # the pelvis's tilt is held by the fit, not measured: no curve, no key value, and the file says why
    assert "pelvis_tilt" not in d["curves"] and "held" in d["not_measured"]["pelvis_tilt"]
    assert d["key_values"]["left"]["pelvis_tilt_rom_deg"]["n"] == 0
    assert d["marker_errors_mm"]["LKnee"]["rms"] < 20
    if norms_file().is_file():  # installed by deploy/bootstrap.sh
        assert "Schwartz" in d["norms"]["source"] and len(d["norms"]["bands"]["knee_flexion"]["mean_deg"]) == 101
        assert "knee_flexion_norm_mean_deg" in (out / "kinematics.csv").read_text().splitlines()[0]
    else:
        assert d["norms"]["bands"] == {}
    c = ezc3d.c3d(str(out / "trajectory.c3d"))
    assert list(c["parameters"]["POINT"]["LABELS"]["value"]) == list(names)
    assert c["parameters"]["POINT"]["RATE"]["value"][0] == pytest.approx(30.0)
    assert np.allclose(c["data"]["points"][:3, names.index("left_heel"), :].T, points[:, names.index("left_heel")],
                       atol=0.01)
    strikes = [s for s in report.steps if np.isfinite(s.heel_strike_s)]
    labels = list(c["parameters"]["EVENT"]["LABELS"]["value"])
    assert labels.count("Foot Strike") == len(strikes)
    trc = (out / "kinematics.trc").read_text().splitlines()
    assert trc[2].split("\t")[4] == "m" and trc[3].split("\t")[2] == "Nose"
    model = opensim.Model(str(out / "kinematics.osim"))
    assert model.getMarkerSet().contains("RKnee") and model.getCoordinateSet().contains("knee_angle_r")


def test_sign_conventions_match_the_model(engine):
    """Each clinical variable's sign, read off the model: moving the coordinate moves a marker the
    anatomical way (OpenSim frame: x forward, y up, z right)."""
    from gaitcap.reconstruction.kinematics.angles import VARIABLES
    from gaitcap.services.kinematics.files import setup_files

    files = setup_files("Halpe26")
    model = opensim.Model(str(files["model"]))
    model.set_MarkerSet(opensim.MarkerSet(str(files["markers"])))
    state = model.initSystem()

    def moved(coordinate: str, marker: str) -> np.ndarray:
        c, m = model.getCoordinateSet().get(coordinate), model.getMarkerSet().get(marker)
        c.setValue(state, 0.0)
        before = m.getLocationInGround(state).to_numpy()
        c.setValue(state, 0.2)
        after = m.getLocationInGround(state).to_numpy()
        c.setValue(state, 0.0)
        return after - before

    def sign(var: str, side: str) -> float:
        return VARIABLES[var].sign[side]

    for side, s in (("right", "R"), ("left", "L")):
        assert sign("knee_flexion", side) * moved(VARIABLES["knee_flexion"].coordinate[side], f"{s}Ankle")[0] < 0
        assert sign("hip_flexion", side) * moved(VARIABLES["hip_flexion"].coordinate[side], f"{s}Knee")[0] > 0
        toe = moved(VARIABLES["ankle_dorsiflexion"].coordinate[side], f"{s}BigToe")
        assert sign("ankle_dorsiflexion", side) * toe[1] > 0
        medial = -1.0 if side == "right" else 1.0  # toward the other leg along z
        assert sign("hip_adduction", side) * moved(VARIABLES["hip_adduction"].coordinate[side], f"{s}Knee")[2] * medial > 0
        # obliquity up on this side: the hip marker of this side rises
        assert sign("pelvis_obliquity", side) * moved("pelvis_list", f"{s}Hip")[1] > 0
        assert sign("pelvis_rotation", side) * moved("pelvis_rotation", f"{s}Hip")[0] > 0
    assert sign("pelvis_tilt", "left") * moved("pelvis_tilt", "Neck")[0] > 0  # anterior: the trunk goes forward
    assert sign("trunk_flexion", "left") * moved("L5_S1_Flex_Ext", "Neck")[0] > 0


def test_missing_setup_files_make_kinematics_unavailable(tmp_path, monkeypatch, fitted):
    from gaitcap.services.kinematics import availability
    from gaitcap.services.kinematics.trial import trial_kinematics

    monkeypatch.setenv("GAITCAP_OPENSIM_DIR", str(tmp_path / "nowhere"))
    ok, reason = availability()
    assert not ok and "bootstrap" in reason
    points, times, names, *_ = fitted
    with pytest.raises(KinematicsUnavailable):
        trial_kinematics(points[:30], times[:30], names, out_dir=tmp_path / "out")
    d = json.loads((tmp_path / "out" / "kinematics.json").read_text())
    assert d == {"available": False, "reason": reason}


def test_a_missing_model_is_said_without_importing_opensim(tmp_path):
    """Where the model is not installed, the engine says so before importing OpenSim (seconds per process)."""
    import subprocess
    import sys

    code = ("import sys; from gaitcap.services.kinematics import availability; ok, why = availability(); "
            "print(ok, 'opensim' in sys.modules, why)")
    env = {**os.environ, "GAITCAP_OPENSIM_DIR": str(tmp_path / "nowhere")}
    out = subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.startswith("False False ") and "not installed" in out.stdout


def test_cli_kinematics(tmp_path, fitted):
    from gaitcap.services.cli import app
    from typer.testing import CliRunner

    points, times, names, *_ = fitted
    npz = tmp_path / "walk.npz"
    np.savez(npz, points_mm=points[:150], times_s=times[:150], joint_names=np.array(names))
    runner = CliRunner()
    res = runner.invoke(app, ["kinematics", str(npz), "--out", str(tmp_path / "k")])
    assert res.exit_code == 0, res.output
    assert "knee_peak_flexion_swing_deg" in res.output and "marker error RMS" in res.output
    assert {p.name for p in (tmp_path / "k").iterdir()} >= {"kinematics.mot", "kinematics.osim", "kinematics.json",
                                                           "kinematics.csv", "kinematics.png", "trajectory.c3d"}
    res = runner.invoke(app, ["kinematics", str(npz), "--mass-kg", "5"])
    assert res.exit_code == 2 and "--mass-kg" in res.output
    res = runner.invoke(app, ["kinematics", str(tmp_path / "none.npz")])
    assert res.exit_code == 2 and "no such file" in res.output


def test_the_returned_report_carries_the_band_written_for_the_age(engine, fitted, tmp_path):
    from gaitcap.services.kinematics.files import adult_norms_file
    from gaitcap.services.kinematics.trial import trial_kinematics

    if not adult_norms_file().is_file():
        pytest.skip("the adult normal-gait bands are not installed (deploy/bootstrap.sh)")
    points, times, names, report, _, _ = fitted
    kin = trial_kinematics(points[:60], times[:60], names, out_dir=tmp_path, age_years=40)
    written = json.loads((tmp_path / "kinematics.json").read_text())["norms"]["bands"]
    assert set(kin.norms) == set(written) and "hip_adduction" not in kin.norms  # the adults' band, not children's
    knee = kin.norms["knee_flexion"].to_dict()
    assert knee == written["knee_flexion"]
