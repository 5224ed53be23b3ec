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
            # measured: hip 0.96 / 1.17 deg, r 0.998 / 0.997; knee 0.63 / 0.52, r 0.999 / 1.000 (hip 1.1 / 1.5
            # and knee 1.5 / 1.3 while the IK stopped at accuracy 1e-3 and the shoulders moved the pelvis)
            assert a.rmse_after_offset_deg <= 1.5 and a.r >= 0.995, (var, side, a)
    for side in ("left", "right"):
        a = agree["ankle_dorsiflexion"][side]
        # measured: 1.72 / 1.15 deg, r 0.984 / 0.996 (2.7 / 2.2, r 0.962 / 0.976 before, see above), peak
        # plantarflexion -26.5 / -35.8 against Plug-in-Gait's -26.9 / -33.6 (it was -17 / -27 with
        # Pose2Sim's foot markers and the subtalar joint on its bound)
        assert a.rmse_after_offset_deg <= 2.0 and a.r >= 0.98, (side, a)
        assert abs(a.trial_min_deg - a.offset_deg - a.reference_min_deg) <= 3.0, (side, a)  # peak plantarflexion
    # the offsets (ours - Plug-in-Gait): hip flexion -5 deg (Plug-in-Gait's pelvis tilts forward, ours is
    # held level), knee +2 (the model's straight knee against Plug-in-Gait's knee axes), ankle about 0 (our
    # foot line at right angles to the shank, Plug-in-Gait's foot flat in its static trial)
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
