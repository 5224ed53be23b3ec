"""One trial's kinematics: model fit, gait-cycle report and exports, written into one folder.

Files (base names fixed, see ``FILES``): the fitted markers (``kinematics.trc``, OpenSim names, y up, m),
the scaled model (``kinematics.osim``), the joint angles (``kinematics.mot``), the report
(``kinematics.json``, curves CSV ``kinematics.csv``, curves with the norm band ``kinematics.png``) and the
trajectories with gait events (``trajectory.c3d``). When kinematics cannot be computed, ``kinematics.json`` says why
(``{"available": false, "reason": ...}``) and the other files are absent.
"""

from __future__ import annotations

import json
import logging
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_write_bytes, atomic_write_text
from gaitcap.reconstruction.kinematics.c3d import c3d_content
from gaitcap.reconstruction.kinematics.markers import guess_skeleton, layout_for
from gaitcap.reconstruction.kinematics.report import KinematicsReport, curves_csv, kinematics_report
from gaitcap.services.kinematics.base import FitRequest, KinematicsUnavailable
from gaitcap.services.kinematics.c3d_file import write_c3d
from gaitcap.services.kinematics.engine import get_engine
from gaitcap.services.kinematics.files import norms_for_age
from gaitcap.services.kinematics.shown import curves_png, with_norms

log = logging.getLogger(__name__)
STEM = "kinematics"
FILES = {"trc": f"{STEM}.trc", "osim": f"{STEM}.osim", "mot": f"{STEM}.mot", "json": f"{STEM}.json",
         "csv": f"{STEM}.csv", "png": f"{STEM}.png", "c3d": "trajectory.c3d"}
MIN_WEIGHT = 0.1


@dataclass(frozen=True)
class KinematicsConfig:
    """engine: registry name (``engine.ENGINES``); mass_kg: the patient's mass (inertia only, no effect on
    the angles)."""

    engine: str = "opensim"
    mass_kg: float = 70.0


def marker_weights(quality: np.ndarray | None, points_mm: np.ndarray) -> np.ndarray:
    """(M,) relative confidence of each marker in [MIN_WEIGHT, 1]: its median number of agreeing views
    (the reconstruction's quality, (T, M)) over the best marker's, times the fraction of frames it has;
    all 1 without a quality array."""
    present = np.isfinite(points_mm).all(axis=-1).mean(axis=0)
    if quality is None or quality.shape != points_mm.shape[:2]:
        return np.clip(present, MIN_WEIGHT, 1.0)
    q = np.where(np.isfinite(quality), quality, 0.0)
    med = np.median(q, axis=0)
    rel = med / med.max() if med.max() > 0 else np.ones_like(med)
    return np.clip(rel * present, MIN_WEIGHT, 1.0)


def write_unavailable(out_dir: Path, reason: str) -> None:
    atomic_write_text(Path(out_dir) / FILES["json"], json.dumps({"available": False, "reason": reason}) + "\n")


def trial_kinematics(points_mm: np.ndarray, times_s: np.ndarray, joint_names, *, steps=(), quality=None,
                     out_dir: Path, age_years: int | None = None,
                     config: KinematicsConfig = KinematicsConfig()) -> KinematicsReport:
    """Fit, report and export one trial into ``out_dir`` (see the module docstring); returns the report.
    ``age_years``: the patient's age at the trial (years; None when not recorded): the files carry the
    normal-gait band the page shows for that age.

    KinematicsUnavailable when the engine cannot run (``kinematics.json`` then says so); ValueError naming
    the problem for unusable input (no hips, knees or ankles; unknown skeleton)."""
    out_dir = Path(out_dir)
    names = tuple(str(n) for n in joint_names)
    pts = np.asarray(points_mm, dtype=np.float64)
    try:
        engine = get_engine(config.engine)
    except KinematicsUnavailable as exc:
        write_unavailable(out_dir, str(exc))
        raise
    layout = layout_for(guess_skeleton(names))
    markers, mpts = layout.select(pts, names)
    q = None if quality is None else np.asarray(quality, dtype=np.float64)[:, [names.index(k) for k, m in
                                                                              layout.markers.items() if k in names]]
    weights = marker_weights(q, mpts)
    t0 = time.perf_counter()
    fit = engine.fit(FitRequest(mpts, np.asarray(times_s, dtype=np.float64), markers, weights, layout.setup,
                                out_dir, STEM, mass_kg=config.mass_kg))
    model = {"engine": engine.name, "setup": layout.setup, "markers": list(markers),
             "marker_weights": {m: round(float(w), 3) for m, w in zip(markers, weights, strict=True)},
             "scale_factors": {b: round(f, 4) for b, f in fit.scale_factors.items()},
             "frames_fitted": int(np.isfinite(fit.coordinates_deg["knee_angle_r"]).sum()) if
             "knee_angle_r" in fit.coordinates_deg else 0, "frames": int(len(fit.times_s)),
             "seconds": {**fit.seconds, "total": round(time.perf_counter() - t0, 3)},
             "angle_zero_offsets_deg": {v: {s: round(d, 2) for s, d in by.items() if np.isfinite(d)}
                                        for v, by in fit.zero_offsets_deg.items()},
             "coordinates_at_bounds": [h.to_dict() for h in fit.bounds]}
    report = kinematics_report(fit.coordinates_deg, fit.times_s, steps, norms=norms_for_age(age_years).bands,
                               marker_errors_mm=fit.marker_errors_mm, model=model, held=fit.held,
                               zero_offsets_deg=fit.zero_offsets_deg, warnings=[h.message() for h in fit.bounds])
    shown = with_norms({"available": True, **report.to_dict()}, age_years)  # the API re-chooses on reading
    atomic_write_text(out_dir / FILES["json"], json.dumps(shown) + "\n")
    atomic_write_text(out_dir / FILES["csv"], curves_csv(shown))
    write_c3d(out_dir / FILES["c3d"], c3d_content(pts, times_s, names, steps))
    atomic_write_bytes(out_dir / FILES["png"], curves_png(shown))
    log.info("kinematics: %d frames, scale %.2f s, IK %.2f s", len(fit.times_s), fit.seconds.get("scale", 0),
             fit.seconds.get("ik", 0))
    return report
