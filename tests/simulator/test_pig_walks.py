"""Real Plug-in-Gait walks read as keypoints: joint centres, heel and toe, a small toe that turns with the
foot, the laboratory's events and angles on the file's own clock."""

from pathlib import Path

import numpy as np
import pytest
from gaitcap.reconstruction.kinematics.foot import foot_frames
from gaitcap.simulator.pig_walks import RATE_HZ, SMALL_TOE_LATERAL_MM, load_pig_walk

C3D_DIR = Path(__file__).resolve().parents[2].parent / "shared" / "data" / "c3d"


def test_functional_walk_as_keypoints():
    pw = load_pig_walk(C3D_DIR / "FunctionalWalk.c3d")
    w = pw.walk
    assert w.rate_hz == RATE_HZ and np.allclose(np.diff(w.times_s), 1 / RATE_HZ)
    assert pw.angle_times_s.size == 438 and w.duration_s == pytest.approx(437 / 120, abs=1e-6)
    # the walk goes along +x, left hip on the left (+y), feet on the floor
    hips = 0.5 * (w.markers_mm["left_hip"] + w.markers_mm["right_hip"])
    assert hips[-1, 0] - hips[0, 0] > 2000 and np.mean(w.markers_mm["left_hip"][:, 1] - w.markers_mm["right_hip"][:, 1]) > 100
    for side, sign in (("left", 1.0), ("right", -1.0)):
        toe, small = w.markers_mm[f"{side}_toe"], w.markers_mm[f"{side}_small_toe"]
        assert np.median(sign * (small[:, 1] - toe[:, 1])) > 0.8 * SMALL_TOE_LATERAL_MM  # lateral of the big toe
        assert np.median(np.linalg.norm(small - toe, axis=1)) == pytest.approx(np.hypot(35.0, 20.0), abs=0.5)
        # on the foot: still in the frame of its heel, toe and ankle (in Plug-in-Gait's foot frame, whose lateral
        # axis is the tibia's, it moved 10-16 mm up and down against them)
        axes = foot_frames(w.markers_mm[f"{side}_ankle"], w.markers_mm[f"{side}_heel"], toe)
        local = np.einsum("tij,tj->ti", axes, small - toe)
        assert np.ptp(local, axis=0).max() < 0.1 and np.allclose(local[0], [-20.0, 0.0, -sign * 35.0], atol=1e-6)
    # the plate-confirmed strikes (README: 5.583, 5.050 and 6.117 s absolute; start (480 - 1) / 120 s)
    assert np.min(np.abs(w.heel_strike_s["left"] - (5.05 - 479 / 120))) < 1e-3
    assert np.min(np.abs(w.heel_strike_s["left"] - (6.1167 - 479 / 120))) < 1e-3
    assert np.min(np.abs(w.heel_strike_s["right"] - (5.5833 - 479 / 120))) < 1e-3
    ankle = pw.angles_deg["ankle_dorsiflexion"]
    assert ankle["left"].min() == pytest.approx(-26.9, abs=0.1) and ankle["right"].min() == pytest.approx(-33.6, abs=0.1)
    assert np.isnan(pw.angles_at(np.array([-1.0]))["knee_flexion"]["left"][0])


def test_a_c3d_without_joint_centres_is_named(tmp_path):
    import ezc3d

    c = ezc3d.c3d()
    c["parameters"]["POINT"]["RATE"]["value"] = [100.0]
    c["parameters"]["POINT"]["LABELS"]["value"] = ["LASI"]
    c["data"]["points"] = np.zeros((4, 1, 10))
    c.write(str(tmp_path / "bare.c3d"))
    with pytest.raises(ValueError, match=r"bare.c3d: C3D: no point 'LFEP'"):
        load_pig_walk(tmp_path / "bare.c3d")
