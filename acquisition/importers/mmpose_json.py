"""MMPose / RTMLib JSON predictions as a keypoint input (one file per camera, camera = file stem).

Two layouts of the file are read, as MMPose writes them:

- ``topdown_demo_with_mmdet.py --save-predictions``: ``{"meta_info": {"dataset_name", "num_keypoints",
  ...}, "instance_info": [{"frame_id": 1, "instances": [{"keypoints": [[x, y], ...], "keypoint_scores":
  [...], "bbox": ...}]}]}``;
- ``MMPoseInferencer`` predictions of a video: ``[{"frame_id": 0, "instances": [...]}, ...]`` (or a list of
  frames that are each a list of instances).

The layout comes from ``meta_info.dataset_name`` when the file has it (``DATASET_LAYOUTS``), else it is
recognised from the keypoints. Frames are matched across cameras by ``frame_id``.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from gaitcap.acquisition.importers.keypoint_input import KeypointInput, make_input, match_cameras
from gaitcap.reconstruction.skeletons import get_skeleton

DATASET_LAYOUTS = {"coco": "coco17", "halpe": "halpe136", "halpe26": "halpe26", "coco_wholebody": "wholebody133",
                   "body8": "coco17", "body7": "coco17"}


def _files(path: Path) -> list[Path]:
    return [path] if path.is_file() else sorted(path.glob("*.json"))


def _looks_like_mmpose(file: Path) -> bool:
    with open(file) as f:
        head = f.read(4096)
    return '"instance_info"' in head or ('"instances"' in head and '"keypoints"' in head) or (
        head.lstrip().startswith("[") and '"keypoint_scores"' in head)


def is_mmpose_input(path: Path) -> bool:
    if path.is_file():
        return path.suffix.lower() == ".json" and _looks_like_mmpose(path)
    files = _files(path) if path.is_dir() else []
    return bool(files) and all(_looks_like_mmpose(f) for f in files)


def _frames(doc, where: str) -> tuple[list[tuple[int, list]], str | None]:
    """[(frame id, instances)] and the dataset name (or None)."""
    dataset = None
    if isinstance(doc, dict):
        dataset = (doc.get("meta_info") or {}).get("dataset_name")
        doc = doc.get("instance_info")
    if not isinstance(doc, list):
        raise ValueError(f"{where}: expected 'instance_info' or a list of frames")
    out = []
    for i, frame in enumerate(doc):
        if isinstance(frame, dict):
            out.append((int(frame.get("frame_id", i)), frame.get("instances", [])))
        elif isinstance(frame, list):
            out.append((i, frame))
        else:
            raise ValueError(f"{where}: frame {i} is neither an object nor a list of instances")
    return out, dataset


def _person(instance: dict, where: str) -> np.ndarray:
    try:
        xy = np.asarray(instance["keypoints"], dtype=np.float64).reshape(-1, 2)
        score = np.asarray(instance.get("keypoint_scores", np.ones(len(xy))), dtype=np.float64).reshape(-1)
    except (KeyError, ValueError) as exc:
        raise ValueError(f"{where}: instance without keypoints [[x, y], ...] ({exc})") from None
    if score.shape[0] != xy.shape[0]:
        raise ValueError(f"{where}: {xy.shape[0]} keypoints but {score.shape[0]} keypoint_scores")
    return np.concatenate([xy, np.clip(score, 0, 1)[:, None]], -1)


def read_mmpose_input(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    files = _files(path)
    per_cam, datasets = [], set()
    for f in files:
        try:
            doc = json.loads(f.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise ValueError(f"{f}: not readable JSON ({exc})") from None
        frames, dataset = _frames(doc, str(f))
        datasets.add(dataset)
        per_cam.append({fid: [_person(p, f"{f} frame {fid}") for p in inst] for fid, inst in frames})
    joints = {len(p) for cam in per_cam for ppl in cam.values() for p in ppl}
    if len(joints) != 1:
        raise ValueError(f"{path}: people with joint counts {sorted(joints)} (need exactly one count)")
    j = joints.pop()
    ids = sorted({fid for cam in per_cam for fid in cam})
    index = {fid: i for i, fid in enumerate(range(ids[0], ids[-1] + 1))}
    most = max(len(ppl) for cam in per_cam for ppl in cam.values())
    kp = np.full((len(files), len(index), most, j, 3), np.nan)
    kp[..., 2] = 0.0
    for c, cam in enumerate(per_cam):
        for fid, ppl in cam.items():
            for p, arr in enumerate(ppl):
                kp[c, index[fid], p] = arr
    dataset = next(iter(datasets)) if len(datasets) == 1 else None
    layout = DATASET_LAYOUTS.get(str(dataset).lower()) if dataset else None
    if layout is not None and get_skeleton(layout).num_joints != j:
        layout = None  # the dataset name does not fit the keypoint count: recognise instead
    names = match_cameras([f.stem for f in files], camera_names)
    return make_input(kp, names, np.arange(len(index)) / fps, layout=layout, rig=None,
                      source=f"MMPose JSON ({dataset or 'no dataset name'})")
