"""The ``gaitcap simulate`` outputs on disk: calibration.toml, keypoints.npz, ground_truth.npz.

keypoints.npz:
    keypoints (C, T, J, 3) float64: x px, y px, confidence (the patient, as if already identified);
    cameras (C,) str; times_s (T,) float64; skeleton str (0-d); clock_offsets_ns (C,) int64;
    jitter_ns (C, T) int64; with several people also multi_keypoints (C, T, P, J, 3) (arbitrary slot
    order per frame) and multi_identity (C, T, P) int64 (ground-truth person of each slot, -1 = empty).
ground_truth.npz:
    points_mm (T, J, 3); times_s (T,); joint_names (J,) str; skeleton str; heel_strike_s_left/right,
    toe_off_s_left/right (n,) s; per step (S): step_foot str, step_heel_strike_s, step_toe_off_s,
    step_heel_mm (S, 3), step_toe_mm (S, 3), step_length_mm, stride_length_mm, step_width_mm (NaN when
    undefined), step_pass int (-1: turning/starting/stopping), step_direction (S, 3), step_kind str;
    params_json str (the WalkParams); preset str; seed int; with several people all_points_mm (P, T, J, 3).
"""

from __future__ import annotations

import json
import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_path
from gaitcap.acquisition.readers import load_rig
from gaitcap.acquisition.writers import save_rig
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints

CALIBRATION = "calibration.toml"
KEYPOINTS = "keypoints.npz"
GROUND_TRUTH = "ground_truth.npz"


def _atomic_savez(path: Path, **arrays) -> None:
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        np.savez_compressed(f, **arrays)


def save_trial(trial, out_dir: str | os.PathLike) -> dict[str, Path]:
    """Write the three files of a trial into ``out_dir`` (created); returns their paths."""
    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    calib = save_rig(
        trial.rig, out / CALIBRATION,
        metadata={"source": "gaitcap synthetic", "preset": trial.preset.name, "seed": int(trial.seed)},
    )
    kp = {
        "keypoints": trial.detections.one_person,
        "cameras": np.array(trial.rig.names, dtype=str),
        "times_s": trial.times_s,
        "skeleton": np.array(trial.skeleton.name),
        "clock_offsets_ns": trial.clock_offsets_ns,
        "jitter_ns": trial.jitter_ns,
    }
    if trial.multi is not None:
        kp["multi_keypoints"] = trial.multi.observed.keypoints
        kp["multi_identity"] = trial.multi.identity
    _atomic_savez(out / KEYPOINTS, **kp)
    t = trial.truth
    gt = {
        "points_mm": trial.points_mm,
        "times_s": trial.times_s,
        "joint_names": np.array(trial.skeleton.joint_names, dtype=str),
        "skeleton": np.array(trial.skeleton.name),
        "heel_strike_s_left": t.heel_strike_s["left"],
        "heel_strike_s_right": t.heel_strike_s["right"],
        "toe_off_s_left": t.toe_off_s["left"],
        "toe_off_s_right": t.toe_off_s["right"],
        **t.steps.as_dict(),
        "params_json": np.array(trial.params.to_json()),
        "preset": np.array(trial.preset.name),
        "seed": np.array(int(trial.seed)),
    }
    if trial.multi is not None:
        gt["all_points_mm"] = trial.multi.points_mm
    _atomic_savez(out / GROUND_TRUTH, **gt)
    return {"calibration": calib, "keypoints": out / KEYPOINTS, "ground_truth": out / GROUND_TRUTH}


@dataclass(frozen=True, eq=False)
class SimulationFiles:
    """What ``load_trial_files`` reads back: the rig, the patient's detections and the raw arrays."""

    rig: Rig
    detections: MultiViewKeypoints
    keypoints: dict[str, np.ndarray]
    ground_truth: dict[str, np.ndarray] | None

    @property
    def params(self):
        from gaitcap.simulator.params import WalkParams

        if self.ground_truth is None:
            raise ValueError("no ground_truth.npz was read")
        return WalkParams.from_json(str(self.ground_truth["params_json"]))


def _load_npz(path: Path) -> dict[str, np.ndarray]:
    if not path.is_file():
        raise FileNotFoundError(f"{path} does not exist")
    with np.load(path, allow_pickle=False) as z:
        return {k: z[k] for k in z.files}


def load_keypoints(path: str | os.PathLike) -> MultiViewKeypoints:
    """keypoints.npz -> MultiViewKeypoints of the patient."""
    kp = _load_npz(Path(path))
    for key in ("keypoints", "cameras", "times_s", "skeleton"):
        if key not in kp:
            raise ValueError(f"{path}: missing array {key!r}")
    return MultiViewKeypoints.of_one_person(kp["keypoints"], tuple(str(c) for c in kp["cameras"]), kp["times_s"], str(kp["skeleton"]))


def load_trial_files(directory: str | os.PathLike, *, ground_truth: bool = True) -> SimulationFiles:
    """Read a ``gaitcap simulate`` output folder."""
    d = Path(directory)
    rig = load_rig(d / CALIBRATION)
    kp = _load_npz(d / KEYPOINTS)
    det = load_keypoints(d / KEYPOINTS)
    gt = _load_npz(d / GROUND_TRUTH) if ground_truth and (d / GROUND_TRUTH).exists() else None
    return SimulationFiles(rig=rig, detections=det, keypoints=kp, ground_truth=gt)


def summary_lines(trial) -> list[str]:
    """A short human-readable ground-truth summary."""
    s = trial.truth.summary()
    p = trial.params
    lines = [
        f"synthetic trial: preset {trial.preset.name}, seed {trial.seed}, {trial.num_frames} frames at "
        f"{trial.fps:g} fps, {len(trial.rig)} cameras, {trial.all_points_mm.shape[0]} people",
        f"steps: {int(s['steps'])} ({int(s['straight_steps'])} on straight passes)",
    ]
    if "step_length_mm" in s:
        lines.append(
            f"mean step length {s['step_length_mm']:.1f} mm, stride {s['stride_length_mm']:.1f} mm, "
            f"step width {s['step_width_mm']:.1f} mm"
        )
    if "cadence_spm" in s:
        lines.append(f"cadence {s['cadence_spm']:.1f} steps/min, speed {s.get('speed_m_s', float('nan')):.2f} m/s")
    if p.step_asymmetry or p.stance_asymmetry:
        lines.append(
            f"asymmetry: {p.short_side} steps {p.side_step_length_mm(p.short_side):.0f} mm, other side "
            f"{p.side_step_length_mm('right' if p.short_side == 'left' else 'left'):.0f} mm"
        )
    return lines


def summary_json(trial) -> str:
    return json.dumps({"preset": trial.preset.name, "seed": trial.seed, **trial.truth.summary()})
