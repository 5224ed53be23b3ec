"""Benchmark: associating several people across cameras and over time, and choosing the patient.

A synthetic trial (the ``paper`` preset: 10 cameras, 30 fps) with several people in view; times the
association (per-frame cross-view grouping + tracking) and the automatic patient selection, and scores
them against the ground truth: identity switches, wrong and missed detections, whether the patient was
chosen, and the patient's MPJPE after robust triangulation of the selected detections compared with the
single-person detections.

    python bench/association.py              # a table
    python bench/association.py --json       # one JSON object on stdout
"""

from __future__ import annotations

import argparse
import json
import logging
import os
import statistics
import sys
import time

import numpy as np


def _mpjpe(points_mm: np.ndarray, truth_mm: np.ndarray) -> float:
    err = np.linalg.norm(points_mm - truth_mm, axis=-1)
    return float(np.nanmean(err))


def run(*, frames: int, cameras: int, people: int, seed: int, repeats: int, mpjpe: bool) -> dict:
    from gaitcap.reconstruction.association import (
        associate,
        default_selector,
        patient_detections,
        score_association,
    )
    from gaitcap.simulator import make_trial

    fps = 30.0
    trial = make_trial(preset="paper", seconds=frames / fps, cameras=cameras, people=people, seed=seed)
    multi = trial.multi.observed
    c_, t_, p_, j_ = multi.shape
    assoc_s, assoc_cpu_s, select_s = [], [], []
    for _ in range(repeats):
        t0, c0 = time.perf_counter(), time.process_time()
        tracks = associate(multi, trial.rig)
        t1, c1 = time.perf_counter(), time.process_time()
        chosen = default_selector(trial.rig).choose(tracks)
        patient = patient_detections(multi, tracks, chosen)
        t2 = time.perf_counter()
        assoc_s.append(t1 - t0)
        assoc_cpu_s.append(c1 - c0)
        select_s.append(t2 - t1)
    score = score_association(tracks.detection_track, trial.multi.identity)
    result = {
        "frames": t_, "cameras": c_, "people": people, "slots": p_, "joints": j_, "seed": seed,
        "detections": score.total,
        "associate_s": min(assoc_s), "associate_median_s": statistics.median(assoc_s),
        "associate_cpu_s": min(assoc_cpu_s), "load_average_1min": os.getloadavg()[0],
        "select_s": min(select_s), "tracks": tracks.num_tracks,
        "identity_switches": score.identity_switches,
        "wrong_fraction": score.wrong_fraction, "missed_fraction": score.missed_fraction,
        "patient_chosen": bool(score.main_track[0] == chosen),
        "patient_frames_covered": float(np.mean(np.isfinite(patient.one_person[..., 0]).any((0, 2)))),
    }
    if mpjpe:
        from gaitcap.reconstruction.triangulation import robust_triangulate

        selected = robust_triangulate(patient, trial.rig).points_mm
        single = robust_triangulate(trial.detections, trial.rig).points_mm
        result["patient_mpjpe_mm"] = _mpjpe(selected, trial.points_mm)
        result["single_person_mpjpe_mm"] = _mpjpe(single, trial.points_mm)
    return result


def _table(r: dict) -> str:
    rows = [
        ("trial", f"{r['frames']} frames x {r['cameras']} cameras x {r['people']} people "
                  f"({r['detections']} detections)"),
        ("association (best)", f"{r['associate_s']:.3f} s wall (median {r['associate_median_s']:.3f} s), "
                               f"{r['associate_cpu_s']:.3f} s CPU; load average {r['load_average_1min']:.1f}"),
        ("selection", f"{r['select_s'] * 1000:.1f} ms"),
        ("tracks", str(r["tracks"])),
        ("identity switches", str(r["identity_switches"])),
        ("wrong / missed detections", f"{100 * r['wrong_fraction']:.2f} % / {100 * r['missed_fraction']:.2f} %"),
        ("patient chosen", "yes" if r["patient_chosen"] else "NO"),
        ("patient frames covered", f"{100 * r['patient_frames_covered']:.1f} %"),
    ]
    if "patient_mpjpe_mm" in r:
        rows.append(("patient MPJPE selected / single", f"{r['patient_mpjpe_mm']:.1f} mm / "
                                                         f"{r['single_person_mpjpe_mm']:.1f} mm"))
    width = max(len(k) for k, _ in rows)
    return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def main(argv: list[str] | None = None) -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--frames", type=int, default=900)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--people", type=int, default=3)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--repeats", type=int, default=3)
    ap.add_argument("--no-mpjpe", action="store_true", help="skip the triangulation comparison")
    ap.add_argument("--json", action="store_true", help="print one JSON object")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    result = run(frames=args.frames, cameras=args.cameras, people=args.people, seed=args.seed,
                 repeats=args.repeats, mpjpe=not args.no_mpjpe)
    print(json.dumps(result) if args.json else _table(result))


if __name__ == "__main__":
    main()
