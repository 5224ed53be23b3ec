"""Keypoints from other tools' files -> :class:`~gaitcap.reconstruction.detections.Detections`.

Supported inputs (:func:`read_keypoints_input` picks by path):

- NPZ: ``keypoints`` (C, T, J, 3) x px, y px, confidence, or (C, T, P, J, 3) with several people;
  ``cameras`` (or ``camera_names``) (C,) names; optional ``times_s`` (T,) and ``skeleton`` (name; else
  inferred from J).
- A folder with one sub-folder of OpenPose-format JSON files per camera (what OpenPose and Pose2Sim
  write): one file per frame, ``people[i].pose_keypoints_2d`` = J x (x, y, confidence); frames matched
  across cameras by the number in the file name; cameras matched to the calibration by name (the
  sub-folder name equals, starts with or contains the camera name) or else by sorted order.
- A trial MCAP written by the recorder.

Several people in a frame: the most confident person per camera and frame (mean confidence), or with
``consistent=True`` and a calibration, the person consistent across views (cross-view association).
"""

from __future__ import annotations

import json
import logging
import re
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.detections import Detections
from gaitcap.reconstruction.skeletons import SKELETONS

log = logging.getLogger(__name__)

DEFAULT_FPS = 30.0
# Joint count -> skeleton when a file does not say (25 is OpenPose BODY_25).
SKELETON_BY_JOINTS = {25: "body25", 26: "halpe26", 17: "coco17", 136: "halpe136", 33: "mediapipe33"}


def infer_skeleton(num_joints: int, name: str | None = None) -> str:
    """Skeleton name given explicitly or inferred from the joint count (ValueError if impossible)."""
    if name:
        if SKELETONS.get(name.lower().replace("-", "").replace("_", "")) is None:
            raise ValueError(f"skeleton: unknown {name!r}; known: {sorted(SKELETONS)}")
        return name
    if num_joints not in SKELETON_BY_JOINTS:
        raise ValueError(
            f"skeleton: cannot infer it from {num_joints} joints (known counts {sorted(SKELETON_BY_JOINTS)}); "
            "name it explicitly"
        )
    return SKELETON_BY_JOINTS[num_joints]


def most_confident_person(people: np.ndarray) -> np.ndarray:
    """(C, T, P, J, 3) -> (C, T, J, 3): per camera and frame the person with the highest mean
    confidence (NaN confidences count as 0)."""
    if people.shape[2] == 0:
        out = np.full(people.shape[:2] + people.shape[3:], np.nan)
        out[..., 2] = 0.0
        return out
    score = np.nan_to_num(people[..., 2]).mean(-1)  # (C, T, P)
    best = np.argmax(score, axis=-1)
    return np.take_along_axis(people, best[:, :, None, None, None], axis=2)[:, :, 0]


def _default_times(num_frames: int, fps: float) -> np.ndarray:
    return np.arange(num_frames) / fps


def read_npz(path: str | Path, *, fps: float = DEFAULT_FPS, skeleton: str | None = None):
    """Read an NPZ keypoint file. Returns (keypoints (C, T, P, J, 3), camera names, times_s, skeleton)."""
    path = Path(path)
    with np.load(path, allow_pickle=False) as data:
        if "keypoints" not in data.files:
            raise ValueError(f"{path}: missing array 'keypoints' (has {sorted(data.files)})")
        name_key = next((k for k in ("cameras", "camera_names") if k in data.files), None)
        if name_key is None:
            raise ValueError(f"{path}: missing array 'cameras' (camera names, one per row of keypoints)")
        kp = np.asarray(data["keypoints"], dtype=np.float64)
        names = tuple(str(n) for n in data[name_key])
        times = np.asarray(data["times_s"], dtype=np.float64) if "times_s" in data.files else None
        skel = skeleton or (str(data["skeleton"]) if "skeleton" in data.files else None)
    if kp.ndim == 4:
        kp = kp[:, :, None]
    if kp.ndim != 5 or kp.shape[-1] != 3:
        raise ValueError(f"{path}: keypoints must be (C, T, J, 3) or (C, T, P, J, 3), got {kp.shape}")
    if len(names) != kp.shape[0]:
        raise ValueError(f"{path}: {len(names)} camera names for {kp.shape[0]} cameras in keypoints")
    if np.isinf(kp).any():
        raise ValueError(f"{path}: keypoints of camera {names[int(np.argwhere(np.isinf(kp))[0, 0])]!r} are infinite")
    times = _default_times(kp.shape[1], fps) if times is None else times
    return kp, names, times, infer_skeleton(kp.shape[3], skel)


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


def match_cameras(folders: list[str], camera_names: list[str] | None) -> list[str]:
    """Camera name for each sub-folder: by name when every folder matches one camera, else by order."""
    if not camera_names:
        return list(folders)

    def match(folder: str) -> str | None:
        hits = [c for c in camera_names if folder == c]
        hits = hits or [c for c in camera_names if folder.startswith(c)]
        hits = hits or [c for c in camera_names if c in folder]
        return max(hits, key=len) if hits else None

    named = [match(f) for f in folders]
    if all(named) and len(set(named)) == len(named):
        return named  # type: ignore[return-value]
    if len(folders) == len(camera_names):
        log.info("camera sub-folders %s matched to the calibration by order", folders)
        return list(camera_names)
    raise ValueError(
        f"camera folders {folders} match neither the calibration's camera names {camera_names} nor their number"
    )


def read_openpose_folder(
    path: str | Path, *, camera_names: list[str] | None = None, fps: float = DEFAULT_FPS, skeleton: str | None = None
):
    """Read an OpenPose JSON folder. Returns (keypoints (C, T, P, J, 3), cameras, times_s, skeleton)."""
    root = Path(path)
    folders = sorted(d.name for d in root.iterdir() if d.is_dir() and any(d.glob("*.json")))
    if not folders:
        raise ValueError(f"{root}: no camera sub-folders with OpenPose .json files")
    names = match_cameras(folders, camera_names)
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
    return kp, tuple(names), np.asarray(frames, dtype=np.float64) / fps - frames[0] / fps, infer_skeleton(j, skeleton)


def _select(kp, names, times, skel, *, rig: Rig | None, consistent: bool) -> Detections:
    if kp.shape[2] > 1 and consistent:
        if rig is None:
            raise ValueError("choosing the person consistent across views needs the calibration")
        from gaitcap.reconstruction.association.multi import MultiPersonDetections
        from gaitcap.reconstruction.association.pipeline import associate_and_select

        multi = MultiPersonDetections(keypoints=kp, camera_names=names, times_s=times, skeleton=skel)
        return associate_and_select(multi, rig.subset(names)).detections
    return Detections(most_confident_person(kp), names, times, skel)


def read_keypoints_input(
    path: str | Path,
    *,
    rig: Rig | None = None,
    fps: float = DEFAULT_FPS,
    skeleton: str | None = None,
    consistent: bool = False,
) -> Detections:
    """Detections from an NPZ file, an OpenPose JSON folder or a trial MCAP (see the module docstring)."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"keypoints input {path} does not exist")
    if path.is_dir():
        data = read_openpose_folder(path, camera_names=rig.names if rig else None, fps=fps, skeleton=skeleton)
    elif path.suffix.lower() == ".npz":
        data = read_npz(path, fps=fps, skeleton=skeleton)
    elif path.suffix.lower() == ".mcap":
        from gaitcap.acquisition.recording.reader import read_keypoints

        rec = read_keypoints(path)
        data = (rec.people, rec.camera_names, rec.times_s, skeleton or rec.skeleton)
    else:
        raise ValueError(f"keypoints input {path}: expected a .npz file, a .mcap trial or an OpenPose JSON folder")
    return _select(*data, rig=rig, consistent=consistent)
