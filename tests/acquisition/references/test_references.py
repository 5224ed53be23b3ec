"""Reading references: the real Plug-in-Gait C3D walks of the shared data (events on the file's own clock,
angles, joint centres), a C3D without events, a walkway export missing a column, a TRC."""

from pathlib import Path

import numpy as np
import pytest
from gaitcap.acquisition.references import read_reference
from gaitcap.reconstruction.trc import to_trc

C3D_DIR = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "c3d"


def test_plug_in_gait_walks_read_with_events_on_their_own_clock():
    ref = read_reference(C3D_DIR / "FunctionalWalk.c3d")
    assert ref.kind == "C3D" and ref.rate_hz == pytest.approx(120.0) and len(ref.times_s) == 438
    # the README's force-plate-confirmed strikes, absolute 5.050 / 6.117 s (left), 5.583 s (right), less the
    # file's first frame (480 - 1) / 120 s
    start = 479 / 120
    assert np.allclose(ref.heel_strike_s["left"][:2], [5.050 - start, 6.1167 - start], atol=2e-3)
    assert np.isclose(ref.heel_strike_s["right"], 5.5833 - start, atol=2e-3).any()
    assert len(ref.toe_off_s["left"]) == 3 and len(ref.toe_off_s["right"]) == 2
    assert ref.labels["left_hip"] == "LFEP" and ref.labels["left_ankle"] == "LTIO" and ref.labels["left_heel"] == "LHEE"
    knee = ref.angles_deg["knee_flexion"]["left"]
    assert knee.shape == (438,) and 50 < np.nanmax(knee) < 80  # swing knee flexion, degrees
    assert ref.lacks == ()
    lower = read_reference(C3D_DIR / "PiG_Motion3_FF.c3d")  # angles stored as ...AnglesV
    assert set(lower.angles_deg) >= {"hip_flexion", "knee_flexion", "ankle_dorsiflexion"}
    assert np.isclose(lower.heel_strike_s["left"], 7.85 - 724 / 100, atol=2e-3).any()


def test_c3d_without_events_says_so(tmp_path):
    import ezc3d

    c = ezc3d.c3d(str(C3D_DIR / "PiG_Motion3_FF.c3d"))
    c["parameters"]["EVENT"]["USED"]["value"] = [0]
    for key in ("CONTEXTS", "LABELS", "DESCRIPTIONS", "SUBJECTS", "ICON_IDS", "GENERIC_FLAGS"):
        if key in c["parameters"]["EVENT"]:
            c["parameters"]["EVENT"][key]["value"] = []
    c["parameters"]["EVENT"]["TIMES"]["value"] = np.zeros((2, 0))
    c.write(str(tmp_path / "no_events.c3d"))
    ref = read_reference(tmp_path / "no_events.c3d")
    assert ref.heel_strike_s is None and not ref.has_events
    assert any("gait events" in x for x in ref.lacks)


def test_walkway_missing_a_column_names_it(tmp_path):
    csv = tmp_path / "walk.csv"
    csv.write_text("foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm\nL,1.0,1.6,0,0,200\n")
    with pytest.raises(ValueError, match="toe_y_mm"):
        read_reference(csv)
    with pytest.raises(ValueError, match="unknown kind"):
        (tmp_path / "walk.xyz").write_text("x")
        read_reference(tmp_path / "walk.xyz")


def test_trc_reads_back_what_gaitcap_writes(tmp_path):
    t = np.arange(10) / 50
    pts = np.random.default_rng(0).normal(0, 300, (10, 2, 3))
    (tmp_path / "m.trc").write_text(to_trc(pts, t, ["left_heel", "right_heel"], units="m"))
    ref = read_reference(tmp_path / "m.trc")
    assert set(ref.joints_mm) == {"left_heel", "right_heel"} and np.allclose(ref.times_s, t)
    # the TRC is in OpenSim's axes (y up): room z becomes Y
    assert np.allclose(ref.joints_mm["left_heel"][:, 1], pts[:, 0, 2], atol=1e-3)
    assert any("events" in x for x in ref.lacks)
