"""Recordings made by other tools: layout recognition, several real people, and ``gaitcap process`` per stage.

    python bench/layouts.py [--json] [--videos]

1. Layout recognition: the same synthetic walk (4 cameras, 1 px noise) written in every registered layout,
   and the real Pose2Sim BODY_25B recordings with their Config.toml hidden: the layout chosen (right or
   wrong), its score and the margin to the next candidate (mm; inf when the keypoint count is unique).
2. Two real people (Pose2Sim demo, 4 cameras, 60 fps, BODY_25B): people tracked, frames where the
   patient's reconstruction switches person (hips' midpoint moving > 150 mm in 1/60 s), the median limb-
   length SD (mm) of each person's robust triangulation.
3. ``gaitcap process`` wall time per stage (s) on the real 4-camera recordings: the two-person keypoints,
   and with ``--videos`` the Pose2Sim 4-camera videos of two people from detection on (MediaPipe with its
   default options: everyone, up to 4 people per image).

The Pose2Sim data are installed by deploy/bootstrap.sh (install_pose2sim_demos).
"""

from __future__ import annotations

import argparse
import json
import logging
import shutil
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from gaitcap.acquisition.installed import share_path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import jsonable  # noqa: E402

DEMOS = share_path("testdata", "pose2sim")
SESSION = DEMOS / "S00_Demo_BatchSession"
REAL = {"pose2sim one person (BODY_25B)": SESSION / "S00_P00_SingleParticipant" / "S00_P00_T01_BalancingTrial",
        "pose2sim two people (BODY_25B)": SESSION / "S00_P01_MultiParticipants" / "S00_P01_T02_Participants1-2"}
SWITCH_MM = 150.0


def _recognise(recording, rig, truth: str) -> dict:
    from gaitcap.reconstruction.layout_guess import AmbiguousLayout
    from gaitcap.services.processing.pipeline import resolve_layout

    try:
        _, choice = resolve_layout(recording, rig, named=None)
    except AmbiguousLayout as exc:
        return {"truth": truth, "chosen": None, "right": False, "score_mm": None, "margin_mm": None, "note": str(exc)}
    return {"truth": truth, "chosen": choice.skeleton, "right": choice.skeleton == truth,
            "score_mm": round(choice.score_of(choice.skeleton).score_mm, 1), "margin_mm": round(choice.margin_mm, 1),
            "candidates": len(choice.scores)}


def synthetic_layouts() -> dict:
    from gaitcap.acquisition.importers.keypoint_input import make_input
    from gaitcap.reconstruction.skeletons import SKELETONS
    from gaitcap.simulator import make_trial
    from gaitcap.simulator.layouts import points_in_layout

    trial = make_trial(preset="paper", seconds=6.0, cameras=4, seed=2)
    rng = np.random.default_rng(0)
    out = {}
    for name in sorted(SKELETONS):
        pts = points_in_layout(trial.points_mm, name)
        px = trial.rig.project(pts) + rng.normal(0, 1.0, (4, *pts.shape[:2], 2))
        kp = np.concatenate([px, np.full(px.shape[:-1] + (1,), 0.9)], -1)
        data = make_input(kp, trial.rig.names, trial.times_s, layout=None, rig=None, source="synthetic")
        out[f"synthetic {name}"] = _recognise(data.recording, trial.rig, name)
    return out


def real_layouts() -> dict:
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.acquisition.importers.tool_folders import read_qca

    rig = read_qca(SESSION / "S00_Calibration" / "Calib.qca.txt")
    out = {}
    for label, trial in REAL.items():
        data = read_keypoints_input(trial / "pose", rig=rig, fps=60)  # the bare JSON folder: no Config.toml
        out[label + ", no config"] = _recognise(data.recording, rig, "body25b")
    return out


def two_people() -> dict:
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.reconstruction.association import ManualTrack
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.services.processing.pipeline import patient_input, preliminary, resolve_layout

    data = read_keypoints_input(REAL["pose2sim two people (BODY_25B)"])
    recording, layout = resolve_layout(data.recording, data.rig, named=data.layout)
    skel = get_skeleton(layout.skeleton)
    _, _, selection = patient_input(recording, data.rig)
    people = []
    for track in selection.tracks.ids:
        det, rig, _ = patient_input(recording, data.rig, selector=ManualTrack(int(track)))
        pts = preliminary(det, rig).points_mm
        hips = 0.5 * (pts[:, skel.index("left_hip")] + pts[:, skel.index("right_hip")])
        jumps = np.linalg.norm(np.diff(hips, axis=0), axis=-1)
        sds = [np.nanstd(np.linalg.norm(pts[:, a] - pts[:, b], axis=-1)) for a, b in skel.limb_indices]
        people.append({"track": int(track), "automatic_patient": int(track) == selection.track_id,
                       "frames": int(np.isfinite(hips).all(-1).sum()), "switches": int((jumps > SWITCH_MM).sum()),
                       "max_hip_step_mm": round(float(np.nanmax(jumps)), 1),
                       "limb_sd_mm": round(float(np.nanmedian(sds)), 1)})
    return {"tracks": int(selection.tracks.num_tracks), "people": people}


def process_times(source: Path, *, videos: bool) -> dict:
    from gaitcap.services.cli.detect import build_detector
    from gaitcap.services.processing.offline import OfflineOptions, load_input, process_input

    out = Path(tempfile.mkdtemp(prefix="gaitcap-process-"))
    try:
        t0 = time.perf_counter()
        factory = (lambda: build_detector("mediapipe", None, [])) if videos else None
        data = load_input(source, calibration=None, options=OfflineOptions(), detector_factory=factory)
        result = process_input(data, out, timings_s={"read" + (" and detect" if videos else ""):
                                                          time.perf_counter() - t0})
        return {"cameras": len(result.cameras), "frames": result.frames, "layout": result.layout.skeleton,
                "tracks": result.selection.tracks.num_tracks if result.selection else 1,
                "stages_s": {k: round(v, 2) for k, v in result.timings_s.items()},
                "total_s": round(sum(result.timings_s.values()), 2)}
    finally:
        shutil.rmtree(out, ignore_errors=True)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--json", action="store_true", help="print one JSON object")
    parser.add_argument("--videos", action="store_true", help="also time gaitcap process on the videos (slow)")
    args = parser.parse_args()
    logging.basicConfig(level=logging.WARNING)
    if not SESSION.is_dir():
        sys.exit(f"Pose2Sim demo recordings not installed at {DEMOS} (run deploy/bootstrap.sh)")
    result = {"layouts": {**synthetic_layouts(), **real_layouts()}, "two_people": two_people(),
              "process": {"pose2sim two people, keypoints": process_times(REAL["pose2sim two people (BODY_25B)"],
                                                                          videos=False)}}
    if args.videos:
        result["process"]["pose2sim two people, videos"] = process_times(DEMOS / "Demo_MultiPerson", videos=True)
    if args.json:
        print(json.dumps(jsonable(result)))
        return
    print(f"{'layout recognition':<44}{'truth':<14}{'chosen':<14}{'right':<7}{'score mm':>9}{'margin mm':>11}")
    for label, r in result["layouts"].items():
        print(f"{label:<44}{r['truth']:<14}{str(r['chosen']):<14}{'yes' if r['right'] else 'NO':<7}"
              f"{r['score_mm'] if r['score_mm'] is not None else '-':>9}{r['margin_mm'] if r['margin_mm'] is not None else '-':>11}")
    two = result["two_people"]
    print(f"\ntwo real people: {two['tracks']} tracks")
    print(f"{'track':>6}{'patient':>9}{'frames':>8}{'switches':>10}{'max hip step mm':>17}{'limb SD mm':>12}")
    for p in two["people"]:
        print(f"{p['track']:>6}{'yes' if p['automatic_patient'] else '':>9}{p['frames']:>8}{p['switches']:>10}"
              f"{p['max_hip_step_mm']:>17}{p['limb_sd_mm']:>12}")
    for label, r in result["process"].items():
        print(f"\ngaitcap process, {label}: {r['cameras']} cameras x {r['frames']} frames, {r['layout']}, "
              f"{r['tracks']} tracks; total {r['total_s']} s")
        for stage, s in r["stages_s"].items():
            print(f"  {stage:<28}{s:>8.2f} s")


if __name__ == "__main__":
    main()
