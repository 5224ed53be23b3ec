"""``gaitcap validate`` on a real walk: FunctionalWalk's Plug-in-Gait markers filmed by the simulated rig
(keypoints at the markers' joint centres, the paper's detector noise) from a known start time and in a
known rigid placement, through ``gaitcap process``, then compared with the original C3D. The tool must find
the lag and the transform it was given, and its event and parameter figures must be those computed here
directly from the C3D. Bad input: another walk, a C3D without events, a walkway file missing a column, a
trial with one side only; ``validate-study`` over a CSV of pairs."""

import json
import shutil
from pathlib import Path

import ezc3d
import numpy as np
import pytest
from gaitcap.acquisition.references import read_reference
from gaitcap.acquisition.writers import save_detections_npz, save_rig
from gaitcap.reconstruction.gait.walkway import WalkwayTrial, walkway_csv_text
from gaitcap.reconstruction.kinematics.angles import VARIABLES
from gaitcap.reconstruction.kinematics.mot import to_mot
from gaitcap.services.cli import app
from gaitcap.simulator.reference_film import film_reference
from typer.testing import CliRunner

C3D_DIR = Path(__file__).resolve().parents[3].parent / "shared" / "data" / "c3d"
WALK = C3D_DIR / "FunctionalWalk.c3d"
START_S = 0.25  # reference time of the trial's first frame: the lag the tool must find
FPS = 30.0


@pytest.fixture(scope="module")
def walk(tmp_path_factory):
    """(process output folder, the filming (transform, start), the reference as read)."""
    tmp = tmp_path_factory.mktemp("validate")
    ref = read_reference(WALK)
    film = film_reference(ref, start_s=START_S, duration_s=ref.times_s[-1] - START_S - 0.1, fps=FPS, yaw_deg=10.0,
                          seed=1)
    save_detections_npz(film.detections, tmp / "kp.npz")
    save_rig(film.rig, tmp / "calib.json")
    res = CliRunner().invoke(app, ["process", str(tmp / "kp.npz"), "--calibration", str(tmp / "calib.json"),
                                   "--out", str(tmp / "proc"), "--no-refine", "--no-kinematics"])
    assert res.exit_code == 0, res.output
    return tmp / "proc", film, ref


def _validate(*args):
    return CliRunner().invoke(app, ["validate", *map(str, args)])


def _c3d_events():
    """Heel strikes and toe offs per side straight from the file (s on the trial's clock)."""
    c = ezc3d.c3d(str(WALK))
    p = c["parameters"]
    rate = float(p["POINT"]["RATE"]["value"][0])
    start = (float(p["TRIAL"]["ACTUAL_START_FIELD"]["value"][0]) - 1) / rate
    times = np.asarray(p["EVENT"]["TIMES"]["value"], float).reshape(-1, 2)[:, 1]
    out = {"Foot Strike": {"left": [], "right": []}, "Foot Off": {"left": [], "right": []}}
    for ctx, label, t in zip(p["EVENT"]["CONTEXTS"]["value"], p["EVENT"]["LABELS"]["value"], times, strict=True):
        out[label][ctx.lower()].append(t - start - START_S)
    return out


def test_validate_finds_the_lag_and_transform_and_the_figures_computed_directly(walk, tmp_path):
    proc, film, ref = walk
    res = _validate(proc, WALK, "--out", tmp_path / "v")
    assert res.exit_code == 0, res.output
    out = json.loads((tmp_path / "v" / "validation.json").read_text())
    assert {p.name for p in (tmp_path / "v").iterdir()} == {"validation.json", "validation.csv", "validation.pdf",
                                                            "bland_altman.png"}
    a = out["alignment"]
    assert abs(a["lag_s"] - START_S) < 0.005  # a sixth of a 30 fps frame
    assert np.abs(np.array(a["rotation"]) - film.rotation).max() < 0.005
    assert np.abs(np.array(a["translation_mm"]) - film.translation_mm).max() < 10.0
    assert a["residual_mm"] < 25.0 and a["markers"]["left_hip"] == "LFEP"

    # events: gaitcap's contacts against the file's events moved by the true lag, matched here directly
    gait = json.loads((proc / "preliminary" / "gait.json").read_text())
    truth = _c3d_events()
    lo, hi = out["common_span_s"][0] + 0.2, out["common_span_s"][1] - 0.2
    for e in out["events"]:
        label, key = ("Foot Strike", "heel_strike_s") if e["kind"] == "heel_strike" else ("Foot Off", "toe_off_s")
        found = np.array([c[key] for c in gait["contacts"]
                          if c["foot"] == e["side"] and c["valid"] and c[key] is not None])
        direct = []
        for t in truth[label][e["side"]]:
            if lo <= t <= hi and len(found) and np.min(np.abs(found - t)) <= 0.25:
                direct.append(found[np.argmin(np.abs(found - t))] - t)
        assert e["n"] == len(direct) >= 1
        assert np.allclose(sorted(np.array(e["trial_s"]) - np.array(e["reference_s"])), sorted(direct), atol=0.005)
    strikes = [e for e in out["events"] if e["kind"] == "heel_strike"]
    assert sum(e["n"] for e in strikes) >= 5 and sum(e["missed"] for e in strikes) == 0

    # step length: the reference's heels (median over each contact, moved by the true transform) here directly
    def heel(side, t0):
        """Median heel marker over the contact from t0 to its toe off (the clip ending first: 0.1 s), room."""
        t1 = min((x for x in truth["Foot Off"][side] if x > t0), default=t0 + 0.1)
        m = (ref.times_s >= t0 + START_S) & (ref.times_s <= t1 + START_S)
        return np.median(ref.joints_mm[f"{side}_heel"][m], axis=0) @ film.rotation.T + film.translation_mm

    other = {"left": "right", "right": "left"}
    fwd = film.rotation[:2, 0] / np.linalg.norm(film.rotation[:2, 0])  # the walk's direction in the room
    direct_bias = []
    for pair in out["step_pairs"]:
        side, t = pair["foot"], pair["reference_heel_strike_s"]
        hs = np.array(truth["Foot Strike"][side])
        k = hs[np.argmin(np.abs(hs - t))]
        prev = max(x for x in truth["Foot Strike"][other[side]] if x < k)
        length = (heel(side, k) - heel(other[side], prev))[:2] @ fwd
        trial_len, ref_len = pair["values"]["step_length_mm"]
        assert abs(ref_len - length) < 3.0
        assert abs(pair["values"]["step_time_s"][1] - (k - prev)) < 1e-6
        direct_bias.append(trial_len - length)
    stats = out["parameters"]["step_length_mm"]["all"]
    assert stats["n"] == len(direct_bias) >= 4
    assert abs(stats["bias"] - np.mean(direct_bias)) < 2.0
    # the statistics of the tool's own pairs: Bland-Altman limits and ICC(A,1) by McGraw & Wong's formula
    x = np.array([p["values"]["step_length_mm"] for p in out["step_pairs"]], float)
    d = x[:, 0] - x[:, 1]
    assert stats["loa_high"] == pytest.approx(d.mean() + 1.96 * d.std(ddof=1))
    assert stats["loa_low"] == pytest.approx(d.mean() - 1.96 * d.std(ddof=1))
    assert stats["mae"] == pytest.approx(np.abs(d).mean())
    n, k = x.shape
    grand = x.mean()
    msr = k * ((x.mean(axis=1) - grand) ** 2).sum() / (n - 1)
    msc = n * ((x.mean(axis=0) - grand) ** 2).sum() / (k - 1)
    mse = ((x - x.mean(axis=1, keepdims=True) - x.mean(axis=0) + grand) ** 2).sum() / ((n - 1) * (k - 1))
    assert stats["icc"] == pytest.approx((msr - mse) / (msr + (k - 1) * mse + k / n * (msc - mse)), abs=1e-6)
    assert out["icc_form"].startswith("ICC(A,1)")
    csv = (tmp_path / "v" / "validation.csv").read_text()
    assert "parameter,step_length_mm,all" in csv and (tmp_path / "v" / "validation.pdf").read_bytes()[:4] == b"%PDF"


def test_angles_are_compared_with_the_reference_models(walk, tmp_path):
    """A kinematics.mot holding Plug-in-Gait's own knee, hip and pelvis curves plus known offsets, and the
    fitted model's zero-pose offsets the page adds (kinematics.json): the tool compares the angles the page
    shows, finds the sum of the two offsets, and nothing left once it is removed."""
    proc, _, ref = walk
    trial = tmp_path / "trial"
    shutil.copytree(proc, trial)
    times = np.arange(0, 3.0, 1 / FPS)
    offsets = {"knee_flexion": 5.0, "hip_flexion": -2.0}
    coords = {}
    for var, off in offsets.items():
        v = VARIABLES[var]
        for side in ("left", "right"):
            curve = np.interp(times + START_S, ref.times_s, ref.angles_deg[var][side]) + off
            coords[v.coordinate[side]] = curve / v.sign[side]
    # the pelvis: Plug-in-Gait's left obliquity and rotation as the model's (one) pelvis; its right side then
    # follows from our sign convention and must meet Plug-in-Gait's own right-side curves
    for var, coordinate in (("pelvis_obliquity", "pelvis_list"), ("pelvis_rotation", "pelvis_rotation")):
        curve = np.interp(times + START_S, ref.times_s, ref.angles_deg[var]["left"])
        coords[coordinate] = curve / VARIABLES[var].sign["left"]
    coords["pelvis_tilt"] = np.zeros_like(times)
    coords["pelvis_tx"], coords["pelvis_tz"] = 1.2 * times, np.zeros_like(times)  # m: walking along +x
    (trial / "preliminary" / "kinematics").mkdir()
    (trial / "preliminary" / "kinematics" / "kinematics.mot").write_text(to_mot(times, coords))
    zero = {"knee_flexion": {"left": 1.5, "right": -0.5}}  # added to the model's angle on the page
    (trial / "preliminary" / "kinematics" / "kinematics.json").write_text(
        json.dumps({"available": True, "model": {"angle_zero_offsets_deg": zero}}))
    res = _validate(trial, WALK, "--out", tmp_path / "v")
    assert res.exit_code == 0, res.output
    out = json.loads((tmp_path / "v" / "validation.json").read_text())
    got = {(a["variable"], a["side"]): a for a in out["angles"]}
    pelvis = ("pelvis_obliquity", "pelvis_rotation")
    assert set(got) == {(v, s) for v in (*offsets, *pelvis) for s in ("left", "right")}
    for side in ("left", "right"):  # against the direction of travel, as the page: the sides' conventions agree
        for var in pelvis:
            a = got.pop((var, side))
            assert abs(a["offset_deg"]) < 0.05 and a["rmse_after_offset_deg"] < 0.1 and a["r"] > 0.999, (var, side)
    for (var, side), a in got.items():
        assert abs(a["offset_deg"] - offsets[var] - zero.get(var, {}).get(side, 0.0)) < 0.2 and a["rmse_after_offset_deg"] < 0.3 and a["r"] > 0.999
        assert len(a["cycles"]) >= 1
    assert (tmp_path / "v" / "angles.png").is_file()
    from pypdf import PdfReader

    report = PdfReader(tmp_path / "v" / "validation.pdf")  # a report a lab can file: 1-2 pages
    text = " ".join(" ".join(p.extract_text().split()) for p in report.pages)
    assert len(report.pages) <= 2 and "Joint angles" in text and "Gait events" in text and "ICC(A,1)" in text


def test_another_walk_or_swapped_sides_are_refused_and_nothing_is_written(walk, tmp_path):
    proc, _, _ = walk
    res = _validate(proc, C3D_DIR / "PiG_Motion-FlatFoot-Full.c3d", "--out", tmp_path / "v")
    assert res.exit_code == 2 and "not the same walk" in res.output
    assert not (tmp_path / "v").exists()
    c = ezc3d.c3d(str(WALK))  # the same walk with every left label made right and back
    labels = c["parameters"]["POINT"]["LABELS"]["value"]
    flip = {"L": "R", "R": "L"}
    c["parameters"]["POINT"]["LABELS"]["value"] = [flip[x[0]] + x[1:] if x[:1] in flip else x for x in labels]
    c.write(str(tmp_path / "swapped.c3d"))
    res = _validate(proc, tmp_path / "swapped.c3d", "--out", tmp_path / "v")
    assert res.exit_code == 2 and "sides are swapped" in res.output, res.output
    assert not (tmp_path / "v").exists()


def test_c3d_without_events_and_walkway_missing_a_column(walk, tmp_path):
    proc, _, _ = walk
    c = ezc3d.c3d(str(WALK))
    c["parameters"]["EVENT"]["USED"]["value"] = [0]
    for key in ("CONTEXTS", "LABELS", "DESCRIPTIONS", "SUBJECTS", "ICON_IDS", "GENERIC_FLAGS"):
        if key in c["parameters"]["EVENT"]:
            c["parameters"]["EVENT"][key]["value"] = []
    c["parameters"]["EVENT"]["TIMES"]["value"] = np.zeros((2, 0))
    c.write(str(tmp_path / "no_events.c3d"))
    res = _validate(proc, tmp_path / "no_events.c3d", "--out", tmp_path / "v", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert abs(out["alignment"]["lag_s"] - START_S) < 0.005  # still aligned, by the markers
    assert out["events"] == [] and out["parameters"] == {}
    assert any("gait events" in x for x in out["not_compared"])
    bad = tmp_path / "walk.csv"
    bad.write_text("foot,first_contact_s,last_contact_s,heel_x_mm,heel_y_mm,toe_x_mm\nL,1.0,1.6,0,0,200\n")
    res = _validate(proc, bad, "--out", tmp_path / "w")
    assert res.exit_code == 2 and "toe_y_mm" in res.output and not (tmp_path / "w").exists()


def test_walkway_reference_aligns_on_its_own_clock(walk, tmp_path):
    """A walkway export of the same walk (footprints from the C3D's heel and toe markers, on a clock 10 s
    ahead): the walkway alignment finds the lag."""
    proc, _, ref = walk
    rows = []
    for side in ("left", "right"):
        for t0 in ref.heel_strike_s[side]:
            after = ref.toe_off_s[side][ref.toe_off_s[side] > t0]
            if len(after):
                m = (ref.times_s >= t0) & (ref.times_s <= after[0])
                rows.append((t0, side, after[0], np.median(ref.joints_mm[f"{side}_heel"][m, :2], axis=0),
                             np.median(ref.joints_mm[f"{side}_big_toe"][m, :2], axis=0)))
    rows.sort(key=lambda r: r[0])
    w = WalkwayTrial("0", tuple(r[1] for r in rows), np.array([r[0] for r in rows]) + 10.0,
                     np.array([r[2] for r in rows]) + 10.0, np.array([r[3] for r in rows]), np.array([r[4] for r in rows]))
    (tmp_path / "walk.csv").write_text(walkway_csv_text([w]))
    res = _validate(proc, tmp_path / "walk.csv", "--out", tmp_path / "v", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout.strip().splitlines()[-1])
    # the foot-speed alignment's own bias on this walk: +39.5 ms measured with 5 ms steps (docs/validation.md,
    # "Walkway"); the bound allows that bias and one 5 ms step more, not a stride or a frame's worth more
    assert 0.0 < out["alignment"]["lag_s"] - (START_S + 10.0) < 0.045
    assert "no shared clock" in out["alignment"]["timing_note"]
    assert out["parameters"]["step_length_mm"]["all"]["n"] >= 2


def test_one_side_only_says_what_was_not_compared(walk, tmp_path):
    proc, _, _ = walk
    trial = tmp_path / "trial"
    shutil.copytree(proc, trial)
    path = trial / "preliminary" / "gait.json"
    gait = json.loads(path.read_text())
    gait["contacts"] = [c for c in gait["contacts"] if c["foot"] == "left"]
    gait["steps"] = [s for s in gait["steps"] if s["foot"] == "left"]
    path.write_text(json.dumps(gait))
    res = _validate(trial, WALK, "--out", tmp_path / "v", "--json")
    assert res.exit_code == 0, res.output
    out = json.loads(res.stdout.strip().splitlines()[-1])
    assert {e["side"] for e in out["events"]} == {"left"}
    assert any("right side events" in x for x in out["not_compared"])
    assert out["parameters"]["step_length_mm"]["right"]["n"] == 0


def test_validate_study_over_a_csv_of_pairs(walk, tmp_path):
    proc, _, _ = walk
    (tmp_path / "pairs.csv").write_text(f"name,trial,reference\nsame,{proc},{WALK}\n"
                                        f"other,{proc},{C3D_DIR / 'PiG_Motion-FlatFoot-Full.c3d'}\n")
    res = CliRunner().invoke(app, ["validate-study", str(tmp_path / "pairs.csv"), "--out", str(tmp_path / "s"),
                                   "--executor", "inline", "--json"])
    assert res.exit_code == 0, res.output
    study = json.loads(res.stdout.strip().splitlines()[-1])
    assert study["pairs_ok"] == 1 and [f["name"] for f in study["failed"]] == ["other"]
    assert "not the same walk" in study["failed"][0]["error"]
    one = json.loads((tmp_path / "s" / "same" / "validation.json").read_text())
    row = next(r for r in study["table"] if r["parameter"] == "step_length_mm")
    assert row["n"] == one["parameters"]["step_length_mm"]["all"]["n"]
    assert row["bias"] == pytest.approx(one["parameters"]["step_length_mm"]["all"]["bias"])
    assert (tmp_path / "s" / "study.csv").read_text().startswith("parameter,n,pairs,bias")
    res = CliRunner().invoke(app, ["validate-study", str(tmp_path / "nothing.csv"), "--out", str(tmp_path / "t")])
    assert res.exit_code == 2 and "nothing.csv" in res.output
