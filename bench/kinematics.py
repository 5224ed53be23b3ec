"""Joint kinematics: accuracy of the OpenSim model fit on the synthetic walker, and its speed.

    python bench/kinematics.py [--preset paper] [--seconds 30] [--cameras 10] [--json] [--real NPZ]

The synthetic walker's true joint angles are measured on its exact keypoints (rigid thigh, shank and foot;
``reconstruction.kinematics.geometric``: the norm sources' joint-centre definitions), and compared frame by
frame with the reported angles of inverse kinematics (IK: the model's angles plus the fitted model's zero
pose measured the same way, as the report does) on three trajectories of the same trial: the ground
truth, the robust triangulation and the default fit (implicit). Per variable (both sides pooled, every
fitted frame including standing and turns): RMSE, bias (mean error) and the SD of the error (RMSE with the
bias removed), degrees; marker RMS error (mm); the mean angles while the walker stands still before its
walk (upright: about 0). Also the thigh's inclination (hip flexion minus anterior pelvic tilt), which
keypoints define without a pelvis orientation. Targets on the default fit of the
``paper`` preset: knee and hip flexion RMSE <= 3 deg, ankle <= 5 deg; scale + IK of the 30 s, 30 fps trial
under 15 s.

``--real NPZ``: a reconstructed real walk (e.g. ``gaitcap process``'s ``preliminary/trajectory.npz``): its
gait cycles when there are steps, and the largest knee flexion per side over the trial, checked for
plausibility (a healthy walker's peak knee flexion in swing is 50-70 deg).
"""

from __future__ import annotations

import argparse
import logging
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_foot_arg, add_trial_args, emit  # noqa: E402

VARIABLES = ("hip_flexion", "hip_adduction", "knee_flexion", "ankle_dorsiflexion")
# reported beside them: the thigh's inclination in the progression plane (model: hip flexion minus anterior
# pelvic tilt), the part of hip flexion that keypoints define without a pelvis orientation
THIGH = "thigh_inclination"
TARGETS_DEG = {"knee_flexion": 3.0, "hip_flexion": 3.0, "ankle_dorsiflexion": 5.0}
SPEED_TARGET_S = 15.0


def true_angles(points_mm, joint_names) -> dict:
    """The walker's joint angles (the joint-centre definitions the report uses)."""
    from gaitcap.reconstruction.kinematics.geometric import keypoint_angles

    angles = keypoint_angles(points_mm, joint_names)
    out = {v: {s: angles[v][s] for s in ("left", "right")} for v in VARIABLES}
    out[THIGH] = out["hip_flexion"]  # the walker's pelvis is upright: its hip flexion is the thigh's inclination
    return out


def fit(points_mm, times_s, joint_names, quality, engine, layout, out_dir: Path) -> tuple[dict, dict, float]:
    from gaitcap.reconstruction.kinematics.angles import clinical_angles
    from gaitcap.reconstruction.kinematics.report import with_zero_offsets
    from gaitcap.services.kinematics.base import FitRequest
    from gaitcap.services.kinematics.trial import marker_weights

    markers, pts = layout.select(points_mm, joint_names)
    idx = [list(joint_names).index(k) for k in layout.markers if k in joint_names]
    weights = marker_weights(None if quality is None else quality[:, idx], pts)
    t0 = time.perf_counter()
    result = engine.fit(FitRequest(pts, times_s, markers, weights, layout.setup, out_dir, "bench"))
    seconds = time.perf_counter() - t0
    angles = with_zero_offsets(clinical_angles(result.coordinates_deg, times_s), result.zero_offsets_deg)
    angles[THIGH] = {s: angles["hip_flexion"][s] - angles["pelvis_tilt"][s] for s in ("left", "right")}
    return angles, result.marker_errors_mm, seconds


def compare(ik: dict, truth: dict, standing: np.ndarray) -> dict:
    """Per variable: RMSE, bias, SD of the error (deg), and the mean of IK and truth over ``standing``."""
    out = {}
    for v in (*VARIABLES, THIGH):
        err = np.concatenate([ik[v][s] - truth[v][s] for s in ("left", "right")])
        err = err[np.isfinite(err)]
        still = {k: float(np.nanmean(np.concatenate([a[v][s][standing] for s in ("left", "right")])))
                 for k, a in (("ik", ik), ("truth", truth))}
        out[v] = {"rmse_deg": float(np.sqrt(np.mean(err**2))), "bias_deg": float(err.mean()),
                  "sd_deg": float(err.std()), "frames": int(err.size // 2),
                  "standing_ik_deg": still["ik"], "standing_truth_deg": still["truth"]}
    return out


def run(*, preset: str, seconds: float, cameras: int, seed: int, foot_hz: float | None = None,
        knee_hz: float | None = None) -> dict:
    from gaitcap.reconstruction.kinematics.markers import layout_for
    from gaitcap.reconstruction.methods import Robust, reconstruct
    from gaitcap.services.kinematics import get_engine
    from gaitcap.simulator.trial import make_trial

    trial = make_trial(preset, seconds=seconds, cameras=cameras, seed=seed)
    names = trial.skeleton.joint_names
    engine, layout = get_engine(), layout_for(trial.skeleton.name)
    truth = true_angles(trial.points_mm, names)
    standing = trial.times_s < trial.plan.walk_start_s - 0.2
    inputs = {"ground truth": (trial.points_mm, None)}
    from _common import implicit_method

    for label, method in (("robust triangulation", Robust()), ("default fit", implicit_method(foot_hz, knee_hz=knee_hz))):
        rec = reconstruct(trial.detections, trial.rig, method=method)
        inputs[label] = (rec.points_mm, rec.quality)
    rows = {}
    with tempfile.TemporaryDirectory() as tmp:
        for label, (pts, quality) in inputs.items():
            ik, errors, secs = fit(pts, trial.times_s, names, quality, engine, layout, Path(tmp))
            rms = [e["rms"] for e in errors.values()]
            rows[label] = {"angles": compare(ik, truth, standing), "marker_rms_mm_mean": float(np.mean(rms)),
                           "marker_rms_mm_worst": float(np.max(rms)),
                           "worst_marker": max(errors, key=lambda m: errors[m]["rms"]), "seconds": secs}
    default = rows["default fit"]
    speed = default["seconds"]  # the input the worker fits
    targets = {f"{v} RMSE <= {lim:g} deg (default fit)": {"value": default["angles"][v]["rmse_deg"],
                                                          "met": bool(default["angles"][v]["rmse_deg"] <= lim)}
               for v, lim in TARGETS_DEG.items()}
    targets[f"scale + IK of the default fit, {seconds:g} s at {trial.fps:g} fps <= {SPEED_TARGET_S:g} s"] = {
        "value": speed, "met": bool(speed <= SPEED_TARGET_S)}
    return {"setup": {"preset": preset, "seconds": seconds, "cameras": cameras, "seed": seed, "foot_hz": foot_hz, "knee_hz": knee_hz,
                      "frames": int(trial.num_frames), "fps": trial.fps, "engine": engine.name,
                      "model": layout.setup},
            "rows": rows, "targets": targets}


def real(npz: Path) -> dict:
    """Kinematics of a reconstructed real walk: cycles and key values when the gait analysis finds steps,
    and the largest knee flexion of each side over the whole trial (the swing peak when a swing is in it)."""
    from gaitcap.reconstruction.kinematics.angles import clinical_angles
    from gaitcap.reconstruction.kinematics.mot import parse_mot
    from gaitcap.services.kinematics.trial import FILES, trial_kinematics
    from gaitcap.services.processing.outputs import read_npz
    from gaitcap.services.processing.pipeline import gait_of

    traj, reproj = read_npz(npz)
    times = traj.times_s
    gait, note = gait_of(traj, reprojection_px=reproj)
    with tempfile.TemporaryDirectory() as tmp:
        t0 = time.perf_counter()
        report = trial_kinematics(traj.points_mm, times, traj.joint_names, out_dir=Path(tmp),
                                  steps=gait.steps if gait is not None else (), quality=traj.quality)
        secs = time.perf_counter() - t0
        mot_times, coords, _ = parse_mot((Path(tmp) / FILES["mot"]).read_text())
    from gaitcap.reconstruction.kinematics.report import with_zero_offsets

    d = report.to_dict()
    knee = with_zero_offsets(clinical_angles(coords, mot_times), d["model"].get("angle_zero_offsets_deg", {}))["knee_flexion"]
    peaks = {s: float(np.nanmax(knee[s])) for s in ("left", "right")}
    return {"file": str(npz), "frames": int(len(times)), "duration_s": float(times[-1] - times[0]),
            "seconds": secs, "gait_note": note,
            "cycles": {s: d["curves"]["knee_flexion"][s]["n_cycles"] for s in ("left", "right")},
            "key_values": d["key_values"], "knee_max_flexion_deg": peaks,
            "marker_rms_mm": {m: e["rms"] for m, e in d["marker_errors_mm"].items()},
            "knee_peak_plausible_50_70": bool(all(50.0 <= v <= 70.0 for v in peaks.values()))}


def print_table(result: dict) -> None:
    s = result["setup"]
    print(f"synthetic '{s['preset']}' trial: {s['cameras']} cameras, {s['frames']} frames at {s['fps']:g} fps "
          f"(seed {s['seed']}); {s['engine']} model {s['model']}; angles in deg, marker errors in mm"
          + (f"; the fit's feet at {s['foot_hz']:g} Hz" if s.get("foot_hz") else "")
          + (f"; the fit's knees at {s['knee_hz']:g} Hz" if s.get("knee_hz") else ""))
    print(f"{'input':<22}{'variable':<20}{'RMSE':>7}{'bias':>7}{'SD':>7}{'standing IK':>12}{'truth':>7}")
    for label, row in result["rows"].items():
        for v, a in row["angles"].items():
            print(f"{label:<22}{v:<20}{a['rmse_deg']:7.2f}{a['bias_deg']:7.2f}{a['sd_deg']:7.2f}"
                  f"{a['standing_ik_deg']:12.2f}{a['standing_truth_deg']:7.2f}")
        print(f"{label:<22}{'marker RMS':<20}{row['marker_rms_mm_mean']:7.1f}  (worst {row['worst_marker']} "
              f"{row['marker_rms_mm_worst']:.1f}); scale + IK {row['seconds']:.1f} s")
    print("\ntargets:")
    for name, t in result["targets"].items():
        print(f"  {'met ' if t['met'] else 'MISS'}  {name}: {t['value']:.2f}")
    if "real" in result:
        r = result["real"]
        print(f"\nreal walk {r['file']}: {r['frames']} frames ({r['duration_s']:.2f} s), gait cycles {r['cycles']}"
              f"{' (' + r['gait_note'] + ')' if r['gait_note'] else ''}; kinematics {r['seconds']:.1f} s")
        print("  largest knee flexion (deg): " + ", ".join(f"{s} {v:.1f}" for s, v in r["knee_max_flexion_deg"].items())
              + f"; within 50-70: {r['knee_peak_plausible_50_70']}")
        rms = r["marker_rms_mm"]
        print(f"  marker RMS (mm): median {np.median(list(rms.values())):.1f}, worst {max(rms, key=rms.get)} "
              f"{max(rms.values()):.1f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    add_trial_args(ap)
    ap.add_argument("--real", type=Path, default=None, help="also check a reconstructed real walk (NPZ)")
    add_foot_arg(ap, knees=True)
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(preset=args.preset, seconds=args.seconds, cameras=args.cameras, seed=args.seed, foot_hz=args.foot_hz,
                 knee_hz=args.knee_hz)
    if args.real is not None:
        result["real"] = real(args.real)
    emit(result, as_json=args.json, table=print_table)


if __name__ == "__main__":
    main()
