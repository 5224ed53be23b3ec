"""The rig check from the walking patient and the refinement of a rig from people.

    python bench/rig_check.py [--json] [--seeds 20] [--moved-seeds 3] [--real-axes 3] [--seconds 20]
        [--sections unmoved,moved,baseline,real,people]

1. Synthetic clinic (10 cameras, "paper" detector noise): ``--seeds`` trials with the rig as calibrated
   (false alarms), and ``--moved-seeds`` trials per case with one camera turned by 0.5, 1, 2 or 5 deg (about
   a random axis) or its centre moved by 20 mm after calibration: detection rate (the moved camera named,
   and no other), error of the estimated rotation (deg: angle between the estimated and the true turn), the check's
   own bound on it (deg, the largest over the camera's axes) and the share of cases whose error lies
   within that bound about every axis,
   MPJPE (mm) of the robust triangulation with the true rig, the stale rig and the rig refined from the
   trial's people (the stale rig as prior; only the flagged camera adjusted, every camera where none was
   flagged; and, for comparison, every camera adjusted), and how far the refined camera is from the
   truth (deg, mm).
2. Real Pose2Sim demo (4 real cameras, Qualisys calibration, OpenPose BODY_25B detections of one person
   balancing, 100 frames at 60 fps): the rig as given, and with one camera's calibration perturbed the same
   ways about ``--real-axes`` random axes: flagged cameras without and with a baseline (the same
   participant's static trial of the session, recorded with the calibration as is: its detections of the
   perturbed camera are displaced to where the camera stood when calibrated), rotation error, median
   reprojection error (px, all cameras) before and after refinement, and the refined camera's rotation
   from its original (deg); and how far the refinement moves that camera from the rig as given (unperturbed:
   where the trial's own keypoints put it, the floor of "back to its original").
3. ``--sections baseline`` (not run by default): the synthetic check against a baseline, each trial judged
   against another patient's walk on the same rig recorded before the camera moved (the clinic's baseline
   is an earlier trial): false alarms in ``--seeds`` trials, detection rate and rotation error per case.
4. From people alone (synthetic, 10 cameras, a 20 s walk, no board): camera centres (mm) and rotations
   (deg) against the truth once the walk's world frame is aligned to the room's, the scale error (%) from
   the entered height, the floor's tilt (deg).

Targets (issue 30): every camera moved >= 1 deg or >= 20 mm flagged, none on unperturbed trials; rotation
within 0.3 deg; refined MPJPE within 10 % of the true rig's; the real camera back within 0.2 deg.
The Pose2Sim data are installed by deploy/bootstrap.sh (install_pose2sim_demos).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.calibration.geometry import rotation_angle_deg, rvec_of
from gaitcap.reconstruction.calibration.people_bundle import refine_rig_from_people
from gaitcap.reconstruction.calibration.rig_check import RigCheck, check_rig
from gaitcap.reconstruction.camera import Rig, rodrigues_to_matrix
from gaitcap.reconstruction.triangulation import robust_triangulate
from gaitcap.simulator.rig_faults import seen_from, with_camera_moved

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import emit  # noqa: E402

log = logging.getLogger("bench.rig_check")

CASES = {"rotated 0.5 deg": (0.5, 0.0), "rotated 1 deg": (1.0, 0.0), "rotated 2 deg": (2.0, 0.0),
         "rotated 5 deg": (5.0, 0.0), "moved 20 mm": (0.0, 20.0)}
REAL_PARTICIPANT = share_path("testdata", "pose2sim") / "S00_Demo_BatchSession" / "S00_P00_SingleParticipant"
REAL_TRIAL = REAL_PARTICIPANT / "S00_P00_T01_BalancingTrial"
REAL_BASELINE = REAL_PARTICIPANT / "S00_P00_T00_StaticTrial"


def stale_rig(rig: Rig, name: str, *, rotation_deg: float, shift_mm: float, seed: int) -> Rig:
    """The calibration camera ``name`` had before it turned by ``rotation_deg`` about a random axis and its
    centre moved by ``shift_mm`` in a random direction (the cameras themselves are ``rig``)."""
    axis, direction = np.random.default_rng(seed).normal(size=(2, 3))
    return with_camera_moved(rig, name, rotation_deg=rotation_deg, shift_mm=shift_mm, axis=axis, direction=direction)


def _rotation_error_deg(check: RigCheck, truth: Rig, stale: Rig, name: str) -> float:
    est = rodrigues_to_matrix(np.radians(check.camera(name).turn_deg))
    return float(rotation_angle_deg(est, truth[name].rotation @ stale[name].rotation.T))


def _within_bound(check: RigCheck, truth: Rig, stale: Rig, name: str) -> bool:
    """Whether the estimated rotation's error about each camera axis (x, y, optical) lies within the bound
    the check gives for it."""
    chk = check.camera(name)
    err = rodrigues_to_matrix(np.radians(chk.turn_deg)) @ (truth[name].rotation @ stale[name].rotation.T).T
    return bool(np.all(np.abs(np.degrees(rvec_of(err))) <= np.asarray(chk.rotation_bound_deg)))


def _bound_deg(check: RigCheck, name: str) -> float:
    """The largest of the check's rotation bounds for camera ``name`` (deg)."""
    return float(max(check.camera(name).rotation_bound_deg))


def _mpjpe_mm(trial, rig: Rig) -> float:
    pts = robust_triangulate(trial.detections, rig).points_mm
    return float(np.nanmean(np.linalg.norm(pts - trial.points_mm, axis=-1)))


def _check(det, rig: Rig, *, baseline=None) -> RigCheck:
    return check_rig(det, rig, robust_triangulate(det, rig).points_mm, baseline=baseline)


def _refined(det, stale: Rig, truth: Rig, name: str, check: RigCheck) -> dict:
    """Camera ``name`` after the refinement from people with every camera adjusted (``all``) and with only
    the flagged ones (``flagged``; none flagged: as ``all``): rotation (deg) and centre (mm) from ``truth``,
    the rig, the solve time (s)."""
    out = {}
    for key, moved in (("all", None), ("flagged", check.moved or None)):
        refined = refine_rig_from_people([det], stale, moved=moved)
        out[key] = {"rig": refined.rig, "time_s": refined.report.solve_time_s,
                    "rotation_deg": float(rotation_angle_deg(refined.rig[name].rotation, truth[name].rotation)),
                    "centre_mm": float(np.linalg.norm(refined.rig[name].center_mm - truth[name].center_mm))}
    return out


def synthetic_unmoved(seeds: int, seconds: float) -> dict:
    from gaitcap.simulator import make_trial

    flagged, fields, times, within = [], [], [], []
    for seed in range(seeds):
        trial = make_trial(preset="paper", seconds=seconds, cameras=10, seed=seed)
        t0 = time.perf_counter()
        check = _check(trial.detections, trial.rig)
        times.append(time.perf_counter() - t0)
        flagged += [f"seed {seed}: {name}" for name in check.moved]
        fields.append(max(c.field_px for c in check.cameras))
        within += [_within_bound(check, trial.rig, trial.rig, c.name) and c.shift_mm <= c.shift_bound_mm
                   for c in check.cameras if c.judged]  # nothing moved: the estimates are the errors
    return {"trials": seeds, "false_alarms": len(flagged), "flagged": flagged,
            "max_field_px": round(max(fields), 2), "check_s": round(float(np.median(times)), 2),
            "cameras_within_bounds": f"{sum(within)}/{len(within)}"}


def synthetic_moved(seeds: int, seconds: float) -> dict:
    from gaitcap.simulator import make_trial

    out = {}
    for label, (rot, shift) in CASES.items():
        rows = []
        for seed in range(seeds):
            trial = make_trial(preset="paper", seconds=seconds, cameras=10, seed=100 + seed)
            name = trial.rig.names[seed % len(trial.rig)]
            stale = stale_rig(trial.rig, name, rotation_deg=rot, shift_mm=shift, seed=seed)
            check = _check(trial.detections, stale)
            ref = _refined(trial.detections, stale, trial.rig, name, check)
            rows.append({
                "detected": check.moved == (name,), "others_flagged": len(set(check.moved) - {name}),
                "rotation_error_deg": _rotation_error_deg(check, trial.rig, stale, name),
                "rotation_bound_deg": _bound_deg(check, name),
                "within_bound": float(_within_bound(check, trial.rig, stale, name)),
                "estimated_shift_mm": check.camera(name).shift_mm,
                "mpjpe_true_mm": _mpjpe_mm(trial, trial.rig), "mpjpe_stale_mm": _mpjpe_mm(trial, stale),
                "mpjpe_refined_mm": _mpjpe_mm(trial, ref["flagged"]["rig"]),
                "mpjpe_refined_all_mm": _mpjpe_mm(trial, ref["all"]["rig"]),
                "refined_rotation_deg": ref["flagged"]["rotation_deg"], "refined_centre_mm": ref["flagged"]["centre_mm"],
                "refined_all_rotation_deg": ref["all"]["rotation_deg"], "refined_all_centre_mm": ref["all"]["centre_mm"],
                "refine_s": ref["flagged"]["time_s"],
            })
        out[label] = _summary(rows)
    return out


def _earlier_patient(seed: int, seconds: float):
    """The baseline of the synthetic clinic's trial ``seed``: another patient's walk (1580 mm tall, 560 mm
    steps) on the same rig, recorded before the camera moved (the clinic's baseline is an earlier trial)."""
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.params import WalkParams

    walk = WalkParams(height_mm=1580.0, step_length_mm=560.0)
    return make_trial(preset="paper", seconds=seconds, cameras=10, seed=seed, walk=walk).detections


def synthetic_baseline(seeds: int, moved_seeds: int, seconds: float) -> dict:
    """The check against a baseline on the synthetic clinic: each trial judged against another patient's
    walk on the same rig (recorded before the camera moved: seen from its calibrated pose); false alarms
    over ``seeds`` trials as calibrated, detection and rotation error per case, and how the baseline was
    used (its cameras' ``baseline``: the synthetic detector leaves no field, so "no field there")."""
    from gaitcap.simulator import make_trial

    flagged, used = [], {}
    for seed in range(seeds):
        trial = make_trial(preset="paper", seconds=seconds, cameras=10, seed=seed)
        check = _check(trial.detections, trial.rig, baseline=_earlier_patient(seed, seconds))
        flagged += [f"seed {seed}: {n}" for n in check.moved]
        for c in check.cameras:
            used[c.baseline] = used.get(c.baseline, 0) + 1
    out = {"trials": seeds, "false_alarms": len(flagged), "flagged": flagged, "baseline_use": used}
    for label, (rot, shift) in CASES.items():
        rows = []
        for seed in range(moved_seeds):
            trial = make_trial(preset="paper", seconds=seconds, cameras=10, seed=100 + seed)
            name = trial.rig.names[seed % len(trial.rig)]
            stale = stale_rig(trial.rig, name, rotation_deg=rot, shift_mm=shift, seed=seed)
            baseline = seen_from(_earlier_patient(100 + seed, seconds), trial.rig, stale, name)
            check = _check(trial.detections, stale, baseline=baseline)
            rows.append((check.moved == (name,), _rotation_error_deg(check, trial.rig, stale, name)))
        out[label] = {"detection_rate": float(np.mean([r[0] for r in rows])),
                      "rotation_error_deg_max": round(float(max(r[1] for r in rows)), 3)}
    return out


def _summary(rows: list[dict]) -> dict:
    out = {"trials": len(rows), "detection_rate": float(np.mean([r["detected"] for r in rows])),
           "others_flagged": int(sum(r["others_flagged"] for r in rows))}
    for key in rows[0]:
        if key not in ("detected", "others_flagged"):
            out[key + "_max" if key.endswith(("error_deg", "_deg", "_centre_mm")) else key] = (
                round(float(np.max([r[key] for r in rows])), 3) if key.endswith(("error_deg", "_deg", "_centre_mm"))
                else round(float(np.mean([r[key] for r in rows])), 2))
    out["refined_vs_true_pct"] = round(100 * (out["mpjpe_refined_mm"] / out["mpjpe_true_mm"] - 1), 1)
    return out


def _real_input(trial: Path):
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.services.processing.pipeline import patient_input, resolve_layout

    data = read_keypoints_input(trial)
    recording, layout = resolve_layout(data.recording, data.rig, named=data.layout)
    det, rig, _ = patient_input(recording, data.rig)
    return det, rig


def _median_reprojection_px(det, rig: Rig) -> float:
    pts = robust_triangulate(det, rig).points_mm
    ok = det.confident(0.5)[:, :, 0] & np.isfinite(pts).all(-1)[None]
    err = np.linalg.norm(rig.project(pts)[..., :2] - det.one_person[..., :2], axis=-1)
    return float(np.median(err[ok]))


def real_demo(axes: int) -> dict:
    det, rig = _real_input(REAL_TRIAL)
    reference, _ = _real_input(REAL_BASELINE)
    name = rig.names[1]
    as_given = _check(det, rig)
    optimum = refine_rig_from_people([det], rig, moved=(name,)).rig[name]  # where this trial's keypoints put it
    out = {"cameras": len(rig), "frames": det.shape[1], "perturbed_camera": name, "axes": axes,
           "baseline_frames": reference.shape[1],
           "as_given": {"flagged": list(as_given.moved), "reprojection_px": round(_median_reprojection_px(det, rig), 2),
                        "fields_px": {c.name: round(c.field_px, 1) for c in as_given.cameras},
                        "flagged_with_baseline": list(_check(det, rig, baseline=reference).moved),
                        "refined_moves_deg": round(float(rotation_angle_deg(optimum.rotation, rig[name].rotation)), 3),
                        "refined_moves_mm": round(float(np.linalg.norm(optimum.center_mm - rig[name].center_mm)), 1)}}
    for label, (rot, shift) in CASES.items():
        rows = []
        for seed in range(axes):
            stale = stale_rig(rig, name, rotation_deg=rot, shift_mm=shift, seed=seed)
            plain = _check(det, stale)
            check = _check(det, stale, baseline=seen_from(reference, rig, stale, name))
            ref = _refined(det, stale, rig, name, check)
            rows.append({
                "flagged_plain": list(plain.moved), "flagged": list(check.moved), "detected": check.moved == (name,),
                "rotation_error_deg": _rotation_error_deg(check, rig, stale, name),
                "rotation_bound_deg": _bound_deg(check, name), "within_bound": _within_bound(check, rig, stale, name),
                "reprojection_stale_px": _median_reprojection_px(det, stale),
                "reprojection_refined_px": _median_reprojection_px(det, ref["flagged"]["rig"]),
                "refined_rotation_deg": ref["flagged"]["rotation_deg"], "refined_centre_mm": ref["flagged"]["centre_mm"],
                "refined_all_rotation_deg": ref["all"]["rotation_deg"], "refined_all_centre_mm": ref["all"]["centre_mm"],
            })
        out[label] = {"detection_rate": float(np.mean([r["detected"] for r in rows])),
                      "flagged_plain": [",".join(r["flagged_plain"]) or "-" for r in rows],
                      "flagged": [",".join(r["flagged"]) or "-" for r in rows],
                      "within_bound": float(np.mean([r["within_bound"] for r in rows])),
                      **{key: round(float(np.max([r[key] for r in rows])), 3)
                         for key in ("rotation_error_deg", "rotation_bound_deg", "refined_rotation_deg", "refined_centre_mm",
                                     "refined_all_rotation_deg", "refined_all_centre_mm")},
                      **{key: round(float(np.mean([r[key] for r in rows])), 2)
                         for key in ("reprojection_stale_px", "reprojection_refined_px")}}
    return out


def people_only(seconds: float) -> dict:
    """The synthetic clinic (10 cameras) calibrated from one walk alone: the rig's shape against the truth
    once the world frame (the walk's, not the room's) is aligned; the scale from the entered height."""
    from gaitcap.reconstruction.calibration.compare import world_change
    from gaitcap.reconstruction.calibration.people_init import calibrate_from_people
    from gaitcap.simulator import make_trial

    trial = make_trial(preset="paper", seconds=seconds, cameras=10, seed=0)
    t0 = time.perf_counter()
    result = calibrate_from_people(trial.detections, trial.rig, height_mm=trial.params.height_mm)
    wall = time.perf_counter() - t0
    ref, got = list(trial.rig), [result.rig[n] for n in trial.rig.names]
    turn, shift = world_change(ref, got)
    aligned = np.stack([turn.T @ (b.center_mm - shift) for b in got])
    truth = np.stack([a.center_mm for a in ref])
    scale = float(np.linalg.norm(aligned - aligned.mean(0)) / np.linalg.norm(truth - truth.mean(0)))
    return {"cameras": len(ref), "seconds": seconds,
            "centre_mm_max": round(float(np.max(np.linalg.norm(aligned - truth, axis=1))), 1),
            "rotation_deg_max": round(float(max(rotation_angle_deg(b.rotation @ turn, a.rotation)
                                                for a, b in zip(ref, got, strict=True))), 3),
            "scale_error_pct": round(100 * (scale - 1), 2),
            "floor_tilt_deg": round(float(np.degrees(np.arccos(np.clip(turn[2, 2], -1, 1)))), 3),
            "stature_mm": round(result.stature_mm, 1), "height_mm": trial.params.height_mm, "time_s": round(wall, 1)}


def table(result: dict) -> str:
    lines = []
    un = result.get("synthetic_unmoved")
    if un:
        lines.append(f"Synthetic, rig as calibrated: {un['false_alarms']} false alarm(s) in {un['trials']} trials "
                     f"(largest field {un['max_field_px']} px; check {un['check_s']} s per trial; cameras whose "
                     f"estimate lies within its bounds: {un['cameras_within_bounds']})")
    if result.get("synthetic_moved"):
        lines.append(f"{'synthetic case':18} {'detected':>8} {'others':>6} {'rot err':>8} {'bound':>6} {'within':>6} "
                     f"{'MPJPE true':>10} "
                     f"{'stale':>7} {'refined':>8} {'vs true':>8} {'cam back':>9} {'centre':>7}   "
                     f"{'all free: MPJPE':>15} {'cam back':>9} {'centre':>7}")
    for label, r in result.get("synthetic_moved", {}).items():
        lines.append(f"{label:18} {r['detection_rate']:8.0%} {r['others_flagged']:6d} "
                     f"{r['rotation_error_deg_max']:7.2f}° {r['rotation_bound_deg_max']:5.2f}° {r['within_bound']:6.0%} "
                     f"{r['mpjpe_true_mm']:8.1f}mm {r['mpjpe_stale_mm']:5.1f}mm "
                     f"{r['mpjpe_refined_mm']:6.1f}mm {r['refined_vs_true_pct']:7.1f}% {r['refined_rotation_deg_max']:8.2f}° "
                     f"{r['refined_centre_mm_max']:5.1f}mm   {r['mpjpe_refined_all_mm']:13.1f}mm "
                     f"{r['refined_all_rotation_deg_max']:8.2f}° {r['refined_all_centre_mm_max']:5.1f}mm")
    base = result.get("synthetic_baseline")
    if base:
        cases = "; ".join(f"{label} {base[label]['detection_rate']:.0%}, rotation within "
                          f"{base[label]['rotation_error_deg_max']:.2f} deg" for label in CASES)
        lines.append(f"\nSynthetic, against another patient's walk as baseline: {base['false_alarms']} false alarm(s) "
                     f"in {base['trials']} trials (cameras' baseline use {base['baseline_use']}); {cases}")
    real = result.get("real")
    if real:
        given = real["as_given"]
        lines.append(f"\nReal Pose2Sim demo ({real['cameras']} cameras, {real['frames']} frames; baseline: the static "
                     f"trial, {real['baseline_frames']} frames): as given flagged {given['flagged'] or 'none'}, with the "
                     f"baseline {given['flagged_with_baseline'] or 'none'}; median reprojection {given['reprojection_px']} "
                     f"px; fields {given['fields_px']}; {real['perturbed_camera']} refined from the rig as given (the "
                     f"trial's own optimum) moves {given['refined_moves_deg']} deg, {given['refined_moves_mm']} mm")
        lines.append(f"{'real case':16} {'no baseline':>26} {'with baseline':>26} {'rot err':>8} {'bound':>6} "
                     f"{'within':>6} {'reproj stale':>12} "
                     f"{'refined':>8} {'cam back':>9} {'centre':>7}   {'all free: back':>14} {'centre':>7}   "
                     f"({real['axes']} axes; max over them)")
        for label in CASES:
            r = real[label]
            lines.append(f"{label:16} {' '.join(r['flagged_plain']):>26} {' '.join(r['flagged']):>26} "
                         f"{r['rotation_error_deg']:7.2f}° {r['rotation_bound_deg']:5.2f}° {r['within_bound']:6.0%} "
                         f"{r['reprojection_stale_px']:10.2f}px "
                         f"{r['reprojection_refined_px']:6.2f}px {r['refined_rotation_deg']:8.2f}° "
                         f"{r['refined_centre_mm']:5.1f}mm   {r['refined_all_rotation_deg']:13.2f}° "
                         f"{r['refined_all_centre_mm']:5.1f}mm")
    people = result.get("people_only")
    if people:
        lines.append(f"\nFrom people alone ({people['cameras']} cameras, {people['seconds']:g} s walk, no board): centres "
                     f"within {people['centre_mm_max']} mm and rotations within {people['rotation_deg_max']} deg of the "
                     f"truth (world frame aligned); scale {people['scale_error_pct']:+.2f} % from the height; floor "
                     f"tilt {people['floor_tilt_deg']} deg; {people['time_s']} s")
    return "\n".join(lines)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--seeds", type=int, default=20, help="unperturbed synthetic trials (false alarms)")
    parser.add_argument("--moved-seeds", type=int, default=3, help="synthetic trials per perturbation")
    parser.add_argument("--real-axes", type=int, default=3, help="random axes per perturbation of the real demo")
    parser.add_argument("--seconds", type=float, default=20.0, help="length of each synthetic trial, s")
    parser.add_argument("--sections", default="unmoved,moved,real,people",
                        help="comma-separated: unmoved, moved, baseline (synthetic, against the first half), real (the "
                             "Pose2Sim demo), people (no board)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    wanted = set(args.sections.split(","))
    result = {}
    if "unmoved" in wanted:
        result["synthetic_unmoved"] = synthetic_unmoved(args.seeds, args.seconds)
    if "moved" in wanted:
        result["synthetic_moved"] = synthetic_moved(args.moved_seeds, args.seconds)
    if "baseline" in wanted:
        result["synthetic_baseline"] = synthetic_baseline(args.seeds, args.moved_seeds, args.seconds)
    if "real" in wanted:
        result["real"] = real_demo(args.real_axes) if REAL_TRIAL.exists() else None
    if "people" in wanted:
        result["people_only"] = people_only(max(args.seconds, 20.0))
    emit(result, as_json=args.json, table=table)


if __name__ == "__main__":
    main()
