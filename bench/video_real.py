"""Benchmark: real 4-camera video (Pose2Sim's demos, 1080 x 1920, 60 fps) reconstructed with default options,
per joint, against the same trial reconstructed from Pose2Sim's own 2D keypoints.

    python bench/video_real.py [--demos single multi] [--json]

Ours: MediaPipe with its default options on the videos (everyone in view), the association's patient, the
default fit (implicit) and the preliminary robust triangulation. Reference: the OpenPose BODY_25B keypoints
Pose2Sim 0.8.4 ships for the same recordings (its demo session; the videos come from Pose2Sim 0.10.49),
robust triangulation through its own calibration (for two people, the track nearest ours). Both are in
the room frame of the demos' Qualisys calibration. Distances are per joint, median over the frames both
have (mm), on the joints both skeletons name (MediaPipe's foot_index as the big toe).

Where the distance comes from, per demo: ``offset removed``: the median once each joint's mean offset in
the pelvis frame (x left hip - right hip, z up) is removed: what remains is not a difference of keypoint
definitions (the hips', ankles' and heels' mean offsets are listed, mm lateral / forward / up, ours minus
the reference); ``best shift``: the time shift of ours (frames, sampled on the fit) that minimises the
median, and the median there: frame timing; ``files offset``: the whole-frame offset between the two
packages' frame numbers that best aligns our robust triangulation with the reference (their frame i is
our frame i + offset), and the fit's median at it; ``robust``: ours without the fit (closer to a per-frame
reference partly because the reference keeps its own per-frame noise); ``walker frames``: frames in
which the chosen track is seen by at least two cameras and its per-frame robust triangulation's hip
midpoint lies within ``WALKER_MM`` of the reference's (the walker followed, not the other person).

The data are installed by deploy/bootstrap.sh (install_pose2sim_demos).
"""

from __future__ import annotations

import argparse
import logging
import sys
import time
from pathlib import Path

import numpy as np
from gaitcap.acquisition.installed import share_path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _common import emit  # noqa: E402

ROOT = share_path("testdata", "pose2sim")
SESSION = ROOT / "S00_Demo_BatchSession"
DEMOS = {
    "single": (ROOT / "Demo_SinglePerson", SESSION / "S00_P00_SingleParticipant" / "S00_P00_T01_BalancingTrial"),
    "multi": (ROOT / "Demo_MultiPerson", SESSION / "S00_P01_MultiParticipants" / "S00_P01_T02_Participants1-2"),
}
ALIASES = {"left_foot_index": "left_big_toe", "right_foot_index": "right_big_toe"}
SHIFTS_FRAMES = np.arange(-2.0, 2.01, 0.25)
FILE_OFFSETS = range(-3, 4)
WALKER_MM = 200.0  # hip midpoint this near the reference's: the walker (the other person is > 1 m away)
OFFSET_JOINTS = ("left_hip", "right_hip", "left_ankle", "right_ankle", "left_heel", "right_heel")


def _ours(videos: Path) -> dict:
    from gaitcap.acquisition.detectors.mediapipe import MediaPipeConfig
    from gaitcap.acquisition.importers.tool_folders import read_qca
    from gaitcap.acquisition.video_detect import detect_videos, find_videos
    from gaitcap.reconstruction.association import associate_and_select
    from gaitcap.reconstruction.methods import METHODS, reconstruct

    t0 = time.perf_counter()
    found = detect_videos(find_videos(videos / "videos"), MediaPipeConfig().build())
    rig = read_qca(videos / "calibration" / "Calib.qca.txt")
    sel = associate_and_select(found, rig)
    detect_s = time.perf_counter() - t0
    fit = reconstruct(sel.detections, rig, method=METHODS["implicit"]())
    robust = reconstruct(sel.detections, rig, method=METHODS["robust"]())
    return {"fit": fit, "robust": robust, "tracks": int(sel.tracks.num_tracks), "detect_s": detect_s,
            "frames": len(found.times_s), "seen": sel.tracks.views[sel.track_id] >= 2}


def _reference(folder: Path, near_mm: np.ndarray):
    """Pose2Sim's 2D keypoints of the trial, the track nearest ``near_mm`` (T, 3) hips, triangulated:
    ((T, J, 3) mm, joint names)."""
    from gaitcap.acquisition.importers.keypoint_files import read_keypoints_input
    from gaitcap.reconstruction.association import ManualTrack, associate_and_select
    from gaitcap.reconstruction.methods import METHODS, reconstruct

    data = read_keypoints_input(folder)
    rec = data.recording
    names = list(rec.skeleton.joint_names)
    sel = associate_and_select(rec, data.rig)
    best, best_d = None, np.inf
    for track in sel.tracks.ids:
        det = associate_and_select(rec, data.rig, ManualTrack(int(track))).detections
        pts = reconstruct(det, data.rig, method=METHODS["robust"]()).points_mm
        d = float(np.nanmedian(np.linalg.norm(_hips(pts, names) - near_mm, axis=-1)))
        if d < best_d:
            best, best_d = pts, d
    return best, names


def _hips(points_mm: np.ndarray, names: list[str]) -> np.ndarray:
    return 0.5 * (points_mm[:, names.index("left_hip")] + points_mm[:, names.index("right_hip")])


def _paired(ours: np.ndarray, ours_names: list[str], ref: np.ndarray, ref_names: list[str]):
    """(T, K, 3) ours and reference on the K joints both name, and the names."""
    pairs = [(i, ref_names.index(ALIASES.get(n, n)), ALIASES.get(n, n)) for i, n in enumerate(ours_names)
             if ALIASES.get(n, n) in ref_names]
    return ours[:, [a for a, _, _ in pairs]], ref[:, [b for _, b, _ in pairs]], [n for *_, n in pairs]


def _pelvis_offsets(diff: np.ndarray, ours: np.ndarray, names: list[str]) -> np.ndarray:
    """(T, K, 3) ``diff`` (mm) in the pelvis frame of ``ours``: lateral (to the left hip), forward, up."""
    lat = ours[:, names.index("left_hip")] - ours[:, names.index("right_hip")]
    lat[:, 2] = 0.0
    x = lat / np.linalg.norm(lat, axis=-1, keepdims=True)
    z = np.broadcast_to([0.0, 0.0, 1.0], x.shape)
    y = np.cross(z, x)
    frame = np.stack([x, y, z], axis=1)  # (T, 3, 3) rows: pelvis axes in the room
    return np.einsum("tab,tkb->tka", frame, diff)


def _offset_removed(local: np.ndarray) -> float:
    """Median distance once each joint's mean offset in the pelvis frame is removed (mm)."""
    return float(np.nanmedian(np.linalg.norm(local - np.nanmean(local, axis=0), axis=-1)))


def _lagged(ours: np.ndarray, ref: np.ndarray, offset: int) -> tuple[np.ndarray, np.ndarray]:
    """Our frames i + offset against the reference's frames i (both (T, ...), the overlap only)."""
    n = min(len(ours), len(ref))
    if offset >= 0:
        return ours[offset:n], ref[:n - offset]
    return ours[:n + offset], ref[-offset:n]


def run_demo(name: str) -> dict:
    from gaitcap.reconstruction.skeletons import get_skeleton

    videos, folder = DEMOS[name]
    ours = _ours(videos)
    names = list(get_skeleton("mediapipe33").joint_names)
    fit = ours["fit"]
    ref, ref_names = _reference(folder, _hips(fit.points_mm, names))
    n = min(len(fit.times_s), len(ref))
    o, r, joints = _paired(fit.points_mm[:n], names, ref[:n], ref_names)
    dist = np.linalg.norm(o - r, axis=-1)  # (T, K)
    dt = float(np.median(np.diff(fit.times_s)))
    shifts = {}
    for s in SHIFTS_FRAMES:
        t = np.clip(fit.times_s[:n] + s * dt, fit.times_s[0], fit.times_s[-1])
        inside = (fit.times_s[:n] + s * dt >= fit.times_s[0]) & (fit.times_s[:n] + s * dt <= fit.times_s[-1])
        so, sr, _ = _paired(fit.sample(t), names, ref[:n], ref_names)
        shifts[float(s)] = float(np.nanmedian(np.linalg.norm(so - sr, axis=-1)[inside]))
    best = min(shifts, key=shifts.get)
    ro, rr, _ = _paired(ours["robust"].points_mm[:n], names, ref[:n], ref_names)
    robust_at = {k: float(np.nanmedian(np.linalg.norm(np.subtract(*_lagged(ro, rr, k)), axis=-1))) for k in FILE_OFFSETS}
    files = min(robust_at, key=robust_at.get)
    hips_apart = np.linalg.norm(_hips(ours["robust"].points_mm[:n], names) - _hips(ref[:n], ref_names), axis=-1)
    walker = ours["seen"][:n] & (hips_apart < WALKER_MM)
    local = _pelvis_offsets(o - r, o, joints)
    mean_local = np.nanmean(local, axis=0)
    return {"frames": n, "walker_frames": int(walker.sum()), "tracks": ours["tracks"], "detect_s": round(ours["detect_s"], 1),
            "median_mm": float(np.nanmedian(dist)),
            "per_joint_mm": {j: float(np.nanmedian(dist[:, k])) for k, j in enumerate(joints)},
            "offset_removed_mm": _offset_removed(local),
            "mean_offset_mm": {j: [round(float(v), 1) for v in mean_local[joints.index(j)]] for j in OFFSET_JOINTS
                               if j in joints},
            "files_offset_frames": files,
            "files_offset_median_mm": float(np.nanmedian(np.linalg.norm(np.subtract(*_lagged(o, r, files)), axis=-1))),
            "best_shift_frames": best, "best_shift_median_mm": shifts[best],
            "robust_median_mm": float(np.nanmedian(np.linalg.norm(ro - rr, axis=-1))),
            "reference_frames": int(np.isfinite(r).all(-1).any(-1).sum())}


def _table(r: dict) -> str:
    demos = list(r["demos"])
    joints = list(r["demos"][demos[0]]["per_joint_mm"])
    lines = ["real video, default options, vs the trial triangulated from Pose2Sim's 2D (median mm)",
             f"{'joint':<18}" + "".join(f"{d:>10}" for d in demos)]
    for j in joints:
        lines.append(f"{j:<18}" + "".join(f"{r['demos'][d]['per_joint_mm'].get(j, float('nan')):>10.1f}" for d in demos))
    rows = (("all joints", "median_mm"), ("offset removed", "offset_removed_mm"),
            ("robust (no fit)", "robust_median_mm"), ("best shift", "best_shift_median_mm"),
            ("  at (frames)", "best_shift_frames"), ("files offset", "files_offset_median_mm"),
            ("  at (frames)", "files_offset_frames"), ("tracks", "tracks"), ("walker frames", "walker_frames"),
            ("frames", "frames"))
    for label, key in rows:
        lines.append(f"{label:<18}" + "".join(f"{r['demos'][d][key]:>10.2f}" if isinstance(r['demos'][d][key], float)
                                              else f"{r['demos'][d][key]:>10}" for d in demos))
    lines.append("mean offset, ours minus reference, in the pelvis frame (mm lateral / forward / up)")
    for j in OFFSET_JOINTS:
        lines.append(f"{j:<18}" + "".join(f"{' / '.join(f'{v:.0f}' for v in r['demos'][d]['mean_offset_mm'][j]):>18}"
                                          for d in demos if j in r['demos'][d]['mean_offset_mm']))
    return "\n".join(lines)


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--demos", nargs="+", default=list(DEMOS), choices=list(DEMOS))
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args(argv)
    logging.basicConfig(level=logging.WARNING, stream=sys.stderr)
    missing = [str(p) for d in args.demos for p in DEMOS[d] if not p.is_dir()]
    if missing:
        raise SystemExit(f"Pose2Sim demos not installed ({', '.join(missing)}): run deploy/bootstrap.sh")
    emit({"demos": {d: run_demo(d) for d in args.demos}}, as_json=args.json, table=_table)
    return 0


if __name__ == "__main__":
    sys.exit(main())
