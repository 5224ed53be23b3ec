"""Joint angles fitted directly to the 2D keypoints (JAX chain, ``reconstruction.kinematics.fit2d``) against
the same angles measured on 3D fits, on the synthetic walker, which knows its angles.

    python bench/kinematics_2d.py [--preset paper] [--seconds 30] [--cameras 10] [--json]

Truth: hip flexion and adduction, knee flexion and ankle dorsiflexion measured on the walker's exact
keypoints (``reconstruction.kinematics.geometric``). Compared, with the same definitions, on: the robust
triangulation's and the default (implicit) fit's 3D keypoints, and the 2D chain fit started from the
robust triangulation. Per variable (both sides, every frame): RMSE, bias and SD of the error (degrees);
seconds of each fit (the triangulation, the implicit fit including its triangulation, the chain's
optimisation after the triangulation; the chain uses the robust triangulation's view weights and start,
as the implicit fit does). The OpenSim IK on the default
fit is bench/kinematics.py (knee 2.40, ankle 3.79, hip flexion 2.13 deg there, with its model's angles).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import add_trial_args, emit  # noqa: E402

VARIABLES = ("hip_flexion", "hip_adduction", "knee_flexion", "ankle_dorsiflexion")


def errors(angles: dict, truth: dict) -> dict:
    """variable -> RMSE, bias, SD of the error (degrees) over both sides' frames where both exist."""
    out = {}
    for var in VARIABLES:
        d = np.concatenate([angles[var][s] - truth[var][s] for s in ("left", "right")])
        d = d[np.isfinite(d)]
        out[var] = {"rmse_deg": float(np.sqrt(np.mean(d**2))), "bias_deg": float(d.mean()), "sd_deg": float(d.std()),
                    "frames": int(d.size)}
    return out


def run(*, preset: str, seconds: float, cameras: int, seed: int) -> dict:
    from gaitcap.reconstruction.fits.common import fill_gaps, reject_spikes
    from gaitcap.reconstruction.kinematics.fit2d import fit_angles_2d
    from gaitcap.reconstruction.kinematics.geometric import keypoint_angles
    from gaitcap.reconstruction.methods import Implicit, Robust, reconstruct
    from gaitcap.simulator.trial import make_trial

    trial = make_trial(preset, seconds=seconds, cameras=cameras, seed=seed)
    names = trial.skeleton.joint_names
    truth = keypoint_angles(trial.points_mm, names)
    det, rows = trial.detections, {}
    t0 = time.perf_counter()
    tri = Robust().triangulate(det, trial.rig)
    rows["robust triangulation"] = {"angles": errors(keypoint_angles(tri.points_mm, names), truth),
                                    "seconds": time.perf_counter() - t0}
    t0 = time.perf_counter()
    rec = reconstruct(det, trial.rig, method=Implicit())
    rows["default fit (implicit)"] = {"angles": errors(keypoint_angles(rec.points_mm, names), truth),
                                      "seconds": time.perf_counter() - t0}
    start = fill_gaps(reject_spikes(tri.points_mm), det.times_s, names)  # the default fit's start, too
    fit = fit_angles_2d(det.one_person, names, trial.rig, det.camera_names, start, weights=tri.camera_weights)
    rows["2D chain fit (from the robust triangulation)"] = {"angles": errors(fit.angles_deg, truth),
                                                           "seconds": fit.seconds, "loss": fit.loss}
    return {"setup": {"preset": preset, "seconds": seconds, "cameras": cameras, "seed": seed,
                      "frames": int(trial.num_frames)}, "rows": rows}


def print_table(result: dict) -> None:
    s = result["setup"]
    print(f"preset {s['preset']}, {s['cameras']} cameras, {s['seconds']:g} s ({s['frames']} frames); "
          "RMSE (bias, SD) in degrees against the walker's true angles")
    print(f"{'input':46s} " + " ".join(f"{v:>22s}" for v in VARIABLES) + f" {'seconds':>8s}")
    for label, row in result["rows"].items():
        cells = " ".join(f"{a['rmse_deg']:6.2f} ({a['bias_deg']:+5.2f}, {a['sd_deg']:4.2f})".rjust(22)
                         for a in row["angles"].values())
        print(f"{label:46s} {cells} {row['seconds']:8.1f}")


def main(argv=None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    add_trial_args(ap)
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING)
    result = run(preset=args.preset, seconds=args.seconds, cameras=args.cameras, seed=args.seed)
    emit(result, as_json=args.json, table=print_table)


if __name__ == "__main__":
    main()
