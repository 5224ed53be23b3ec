"""What gaitcap wrote for one trial, as the validation reads it: a stage folder's trajectory, gait
report and joint angles (``<trial>/<stage>/trajectory.npz``, ``gait.json``, ``kinematics/kinematics.mot``).
The angles are the ones the page and the report show: the model's coordinates with the fitted model's
zero-pose offsets (``kinematics.json``'s ``model.angle_zero_offsets_deg``) added, as
:func:`~gaitcap.reconstruction.kinematics.report.kinematics_report` adds them.
The trial is a ``gaitcap process`` output folder or a clinic trial folder (same layout); the stage is the
last one present (refined, else preliminary) unless named."""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.kinematics.angles import VARIABLES, pelvis_in_progression
from gaitcap.reconstruction.kinematics.mot import parse_mot
from gaitcap.reconstruction.kinematics.report import with_zero_offsets
from gaitcap.services.processing.artifacts import STAGE_FILES, STAGES
from gaitcap.services.processing.outputs import read_npz

SIDES = ("left", "right")
ANGLE_VARIABLES = ("pelvis_obliquity", "pelvis_rotation", "hip_flexion", "hip_adduction", "hip_rotation",
                   "knee_flexion", "ankle_dorsiflexion")


@dataclass(frozen=True, eq=False)
class TrialData:
    """source: folder; stage; times_s (T,) frame times (s); joints_mm: joint -> (T, 3) mm (room, z up);
    fps; events: kind -> side -> (K,) s; steps: the gait report's step dicts; angles_deg: variable ->
    side -> (T_k,) at ``angle_times_s``; lacks: what is not there, in words."""

    source: str
    stage: str
    times_s: np.ndarray
    joints_mm: dict[str, np.ndarray]
    fps: float
    events: dict[str, dict[str, np.ndarray]]
    steps: list[dict]
    angle_times_s: np.ndarray = field(default_factory=lambda: np.zeros(0))
    angles_deg: dict[str, dict[str, np.ndarray]] = field(default_factory=dict)
    lacks: tuple[str, ...] = ()


def find_stage(folder: Path, stage: str | None = None) -> str:
    """The stage to read (ValueError naming the folder when it holds none)."""
    folder = Path(folder)
    if not folder.is_dir():
        raise ValueError(f"trial {folder}: not a folder (give a gaitcap process output or a trial folder)")
    present = [s for s in STAGES if (folder / s / STAGE_FILES["trajectory_npz"]).is_file()]
    if stage is not None:
        if stage not in present:
            raise ValueError(f"trial {folder}: stage {stage!r} has no {STAGE_FILES['trajectory_npz']} "
                             f"(present: {', '.join(present) or 'none'})")
        return stage
    if not present:
        raise ValueError(f"trial {folder}: no stage folder ({', '.join(STAGES)}) with a "
                         f"{STAGE_FILES['trajectory_npz']}: not a gaitcap process output or trial folder")
    return present[-1]


def _angles(folder: Path) -> tuple[np.ndarray, dict, str]:
    mot = folder / STAGE_FILES["kinematics_mot"]
    if not mot.is_file():
        status = folder / STAGE_FILES["kinematics_json"]
        why = json.loads(status.read_text()).get("reason", "") if status.is_file() else "no kinematics.mot"
        return np.zeros(0), {}, f"joint angles (kinematics not computed: {why or 'no kinematics.mot'})"
    times, coords, in_degrees = parse_mot(mot.read_text())
    if not in_degrees:  # the rotations; the translations (pelvis_tx, ...) stay in m
        coords = {k: v if k.endswith(("_tx", "_ty", "_tz")) else np.degrees(v) for k, v in coords.items()}
    coords = pelvis_in_progression(coords, times)  # as the page's curves: the pelvis against the walk, not the room
    out = {}
    for var in ANGLE_VARIABLES:
        try:
            out[var] = {s: VARIABLES[var].of(coords, s) for s in SIDES}
        except KeyError:
            continue
    return times, with_zero_offsets(out, _zero_offsets(folder)), ""


def _zero_offsets(folder: Path) -> dict[str, dict[str, float]]:
    """variable -> side -> degrees the page adds to the model's angle (none when not recorded)."""
    status = folder / STAGE_FILES["kinematics_json"]
    data = json.loads(status.read_text()) if status.is_file() else {}
    return (data.get("model") or {}).get("angle_zero_offsets_deg") or {}


def load_trial(folder: str | Path, stage: str | None = None) -> TrialData:
    folder = Path(folder)
    stage = find_stage(folder, stage)
    sdir = folder / stage
    traj, _ = read_npz(sdir / STAGE_FILES["trajectory_npz"])
    joints = {n: traj.points_mm[:, k] for k, n in enumerate(traj.joint_names)}
    fps = 1.0 / float(np.median(np.diff(traj.times_s)))
    lacks = []
    gait_path = sdir / STAGE_FILES["gait_json"]
    events = {k: {s: np.zeros(0) for s in SIDES} for k in ("heel_strike", "toe_off")}
    steps: list[dict] = []
    if gait_path.is_file():
        gait = json.loads(gait_path.read_text())
        contacts = [c for c in gait.get("contacts", []) if c.get("valid", True)]
        for kind in events:
            for s in SIDES:
                events[kind][s] = np.array([c[f"{kind}_s"] for c in contacts
                                            if c["foot"] == s and c.get(f"{kind}_s") is not None], float)
        steps = list(gait.get("steps", []))
    else:
        lacks.append(f"gait events and parameters (no {gait_path.name}: the gait analysis found no steps)")
    angle_times, angles, why = _angles(sdir)
    if why:
        lacks.append(why)
    return TrialData(str(folder), stage, np.asarray(traj.times_s, float), joints, fps, events, steps,
                     angle_times, angles, tuple(lacks))
