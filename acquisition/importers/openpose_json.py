"""OpenPose-format JSON (what OpenPose, Pose2Sim and Sports2D write): a folder with one sub-folder per
camera, one file per frame, ``people[i].pose_keypoints_2d`` = J x (x, y, confidence); frames matched across
cameras by the number in the file name."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

_FRAME_NUMBER = re.compile(r"(\d+)(?!.*\d)")


def _frame_files(folder: Path) -> dict[int, Path]:
    files = sorted(folder.glob("*.json"))
    out = {}
    for i, f in enumerate(files):
        m = _FRAME_NUMBER.search(f.stem)
        out[int(m.group(1)) if m else i] = f
    return out


def _read_people(file: Path) -> list[np.ndarray]:
    try:
        doc = json.loads(file.read_text())
    except (OSError, json.JSONDecodeError) as exc:
        raise ValueError(f"{file}: not a readable OpenPose JSON file ({exc})") from None
    people = []
    for i, person in enumerate(doc.get("people", [])):
        flat = np.asarray(person.get("pose_keypoints_2d", []), dtype=np.float64)
        if flat.size % 3:
            raise ValueError(f"{file}: people[{i}].pose_keypoints_2d has {flat.size} values, not a multiple of 3")
        if flat.size:
            people.append(flat.reshape(-1, 3))
    return people


def openpose_people(root: Path) -> tuple[np.ndarray, list[str], np.ndarray]:
    """An OpenPose JSON folder -> (people (C, T, P, J, 3), sub-folder names, frame numbers (T,))."""
    folders = sorted(d.name for d in root.iterdir() if d.is_dir() and any(d.glob("*.json")))
    if not folders:
        raise ValueError(f"{root}: no camera sub-folders with OpenPose .json files")
    per_cam = {f: _frame_files(root / f) for f in folders}
    numbers = {n for files in per_cam.values() for n in files}
    frames = list(range(min(numbers), max(numbers) + 1))  # frames no camera has stay missing (NaN)
    index = {n: i for i, n in enumerate(frames)}
    parsed = {f: {n: _read_people(p) for n, p in files.items()} for f, files in per_cam.items()}
    joints = {len(p) for cam in parsed.values() for ppl in cam.values() for p in ppl}
    if len(joints) > 1:
        raise ValueError(f"{root}: people with different joint counts {sorted(joints)}")
    if not joints:
        raise ValueError(f"{root}: no person detected in any file")
    j = joints.pop()
    most = max(len(ppl) for cam in parsed.values() for ppl in cam.values())
    kp = np.full((len(folders), len(frames), most, j, 3), np.nan)
    kp[..., 2] = 0.0
    for c, f in enumerate(folders):
        for n, ppl in parsed[f].items():
            for p, arr in enumerate(ppl):
                kp[c, index[n], p] = arr
    kp[..., 2] = np.clip(kp[..., 2], 0.0, 1.0)
    missing_xy = kp[..., 2] <= 0  # OpenPose writes 0, 0, 0 for joints it did not find
    kp[missing_xy, :2] = np.nan
    return kp, folders, np.asarray(frames, dtype=np.float64)
