"""The model fit on a real walk against the laboratory's own Plug-in-Gait angles: FunctionalWalk's joint
centres, heel and toe (``simulator/pig_walks``) at 30 fps through the kinematics of a trial, compared frame
by frame after a constant offset (``bench/kinematics_real.py`` measures all three walks, also through the
rig and ``process_trial``)."""

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("opensim", reason="the kinematics extra (opensim) is not installed")
C3D_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "c3d"


def _fit(pts, times, out):
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.services.kinematics import KinematicsUnavailable
    from gaitcap.services.kinematics.trial import trial_kinematics
    from gaitcap.simulator.mocap import SKELETON

    try:
        return trial_kinematics(pts, times, SKELETON.joint_names,
                                steps=analyze_gait(pts, times, list(SKELETON.joint_names)).steps, out_dir=out)
    except KinematicsUnavailable as exc:
        pytest.skip(f"OpenSim setup files not installed: {exc}")


@pytest.fixture(scope="module")
def walk():
    from gaitcap.simulator.mocap import halpe26_points
    from gaitcap.simulator.pig_walks import load_pig_walk

    pw = load_pig_walk(C3D_DIR / "FunctionalWalk.c3d")
    idx = np.arange(0, len(pw.walk.times_s), 4)  # 120 Hz -> 30 fps
    return pw, pw.walk.times_s[idx], halpe26_points(pw.walk)[idx]


@pytest.fixture(scope="module")
def fitted(walk, tmp_path_factory):
    pw, times, pts = walk
    out = tmp_path_factory.mktemp("kin")
    return pw, out, _fit(pts, times, out)


def _agreement(pw, out: Path) -> dict:
    """variable -> side -> the reported angles' agreement with Plug-in-Gait's (the page's angles: the model's
    plus its zero pose measured like the keypoints)."""
    from gaitcap.reconstruction.kinematics.angles import clinical_angles
    from gaitcap.reconstruction.kinematics.mot import parse_mot
    from gaitcap.reconstruction.kinematics.report import with_zero_offsets
    from gaitcap.reconstruction.validation.angles import compare_angle

    times, coords, _ = parse_mot((out / "kinematics.mot").read_text())
    d = json.loads((out / "kinematics.json").read_text())
    angles = with_zero_offsets(clinical_angles(coords, times), d["model"]["angle_zero_offsets_deg"])
    return {v: {s: compare_angle(v, s, times, angles[v][s], pw.angle_times_s, pw.angles_deg[v][s], lag_s=0.0)
                for s in ("left", "right")} for v in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")}


def test_joint_angles_follow_plug_in_gait_after_a_constant_offset(fitted):
    pw, out, _ = fitted
    agree = _agreement(pw, out)
    for var in ("hip_flexion", "knee_flexion"):
        for side in ("left", "right"):
            a = agree[var][side]
            # measured: hip 0.97 / 1.24 deg, r 0.998 / 0.997; knee 0.56 / 0.52, r 1.000 / 1.000 (hip 1.1 / 1.5
            # and knee 1.5 / 1.3 while the IK stopped at accuracy 1e-3 and the shoulders moved the pelvis)
            assert a.rmse_after_offset_deg <= 1.5 and a.r >= 0.995, (var, side, a)
    for side in ("left", "right"):
        a = agree["ankle_dorsiflexion"][side]
        # measured: 1.76 / 1.29 deg, r 0.984 / 0.995 (2.7 / 2.2, r 0.962 / 0.976 before, see above), peak
        # plantarflexion -26.9 / -36.2 against Plug-in-Gait's -26.9 / -33.6 (it was -17 / -27 with
        # Pose2Sim's foot markers and the subtalar joint on its bound)
        assert a.rmse_after_offset_deg <= 2.0 and a.r >= 0.98, (side, a)
        assert abs(a.trial_min_deg - a.offset_deg - a.reference_min_deg) <= 3.0, (side, a)  # peak plantarflexion
    # the offsets (ours - Plug-in-Gait): hip flexion -5.6 deg (Plug-in-Gait's pelvis tilts forward 5.9 deg
    # on average, ours is held level), knee +0.9 / +0.4 (the straight leg through the joint centres against
    # Plug-in-Gait's femur and tibia axes; +1.5 / +1.0 with the knee marker above the knee's axis), ankle
    # -0.7 / -2.6 (our foot line at right angles to the shank, Plug-in-Gait's foot flat in its static trial)
    off = {v: np.mean([agree[v][s].offset_deg for s in ("left", "right")]) for v in agree}
    assert -7.0 < off["hip_flexion"] < -3.0 and 0.0 < off["knee_flexion"] < 4.0 and abs(off["ankle_dorsiflexion"]) < 2.0
    # no joint of the foot rests on a bound (the subtalar joint sat on its -20 deg bound before); what does
    # (a knee straighter than the model's zero) is a warning in the file
    d = json.loads((out / "kinematics.json").read_text())
    hits = d["model"]["coordinates_at_bounds"]
    assert not [h for h in hits if not h["coordinate"].startswith("knee_angle")], hits
    assert len(d["warnings"]) == len(hits)


def test_the_same_walk_along_the_rooms_diagonal_reads_the_same_angles(walk, fitted, tmp_path):
    """The pelvis's tilt is held along the walkway, not about the room's axes (``walkway``): turned 45 deg
    about the vertical (as the rig films it), the walk's angles stay (hip flexion read 2.2-3.5 deg RMSE
    through the rig before, from the hips' obliquity tilting the pelvis)."""
    from gaitcap.reconstruction.kinematics.walkway import turned_points

    pw, times, pts = walk
    _fit(turned_points(pts, np.radians(-45.0)), times, tmp_path)
    straight, diagonal = _agreement(pw, fitted[1]), _agreement(pw, tmp_path)
    for var in ("hip_flexion", "knee_flexion", "ankle_dorsiflexion"):
        for side in ("left", "right"):
            a, b = straight[var][side], diagonal[var][side]
            # measured: within 0.013 deg; with the tilt held about the room's z the diagonal's hip flexion read
            # 3.4 / 4.0 deg RMSE after the offset (against 0.96 / 1.17) and its offset moved by 1.1 deg
            assert abs(a.offset_deg - b.offset_deg) < 0.1 and abs(a.rmse_after_offset_deg - b.rmse_after_offset_deg) < 0.1, (
                var, side, a, b)


@pytest.mark.parametrize("name", ["PiG_Motion-FlatFoot-Full", "PiG_Motion3_FF"])
def test_knee_and_ankle_of_the_other_walks_joint_centres(name, tmp_path):
    """The knee markers on the knees' axes (``model_setup``): the keypoints' knee is the knee joint centre,
    and with Pose2Sim's marker 10 mm above the axis the model's shank was not the keypoints' knee -> ankle
    line once the knee bent. Measured (knee RMSE after the offset, left / right, and the ankle's r):
    PiG_Motion-FlatFoot-Full knee 0.77 / 1.35 deg (1.05 / 1.73 before), ankle r 0.982 / 0.976 (0.979 /
    0.971); PiG_Motion3_FF knee 1.09 / 0.94 (1.41 / 1.25), ankle r 0.988 / 0.982 (0.985 / 0.977)."""
    from gaitcap.simulator.mocap import halpe26_points
    from gaitcap.simulator.pig_walks import load_pig_walk

    pw = load_pig_walk(C3D_DIR / f"{name}.c3d")
    idx = np.arange(0, len(pw.walk.times_s), 4)  # 120 Hz -> 30 fps
    _fit(halpe26_points(pw.walk)[idx], pw.walk.times_s[idx], tmp_path)
    agree = _agreement(pw, tmp_path)
    for side in ("left", "right"):
        knee = agree["knee_flexion"][side]
        assert knee.rmse_after_offset_deg <= 1.5 and knee.r >= 0.995, (side, knee)
        if name == "PiG_Motion3_FF":
            assert agree["ankle_dorsiflexion"][side].r >= 0.98, (side, agree["ankle_dorsiflexion"][side])
