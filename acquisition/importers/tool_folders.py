"""Other tools' project folders as keypoint inputs (see :mod:`gaitcap.acquisition.importers.keypoint_files`).

- **Pose2Sim** (a trial folder, or a project whose ``Config.toml`` is in it or in a parent): 2D keypoints in
  ``pose/<camera>_json/`` (OpenPose JSON, one file per frame, every person); the layout from the nearest
  ``Config.toml`` that sets ``[pose] pose_model`` (a trial's config inherits its session's, as in Pose2Sim);
  ``[project] frame_rate``; the calibration from a folder whose name contains "calib" in the trial folder or
  up to two parents: a Pose2Sim/aniposelib ``.toml`` (metres), else a Qualisys ``.qca.txt`` converted as
  Pose2Sim's ``calib_qca_fun`` does.
- **anipose / aniposelib**: ``calibration.toml`` (in the folder or ``calibration/``) and one DeepLabCut CSV
  per camera (``pose-2d/`` or the folder itself; header rows scorer / bodyparts / coords, columns x, y,
  likelihood); the layout from the body-part names.
- **FreeMoCap** recording folder: ``*camera_calibration.toml`` (aniposelib format) and
  ``output_data/raw_data/mediapipe*2dData*.npy`` (cameras, frames, points, x/y px): its first 33 points
  are MediaPipe's body. The file has no confidences: a seen point counts as confidence 1.

aniposelib TOML translations are in the unit the calibration board was measured in: a rig whose
cameras are more than ``MM_SPREAD`` "metres" apart is read as millimetres (logged).
"""

from __future__ import annotations

import csv
import logging
import re
import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.importers.keypoint_input import KeypointInput, make_input, match_cameras
from gaitcap.acquisition.importers.openpose_json import openpose_people
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.reconstruction.skeletons import SKELETONS

log = logging.getLogger(__name__)
MM_SPREAD = 100.0  # camera spread above this many file units: the TOML is in mm, not m

# Pose2Sim's pose_model names -> ours.
POSE2SIM_MODELS = {
    "body_25b": "body25b", "body_25": "body25", "coco": "coco18", "coco_17": "coco17", "body": "coco17",
    "halpe_26": "halpe26", "body_with_feet": "halpe26", "halpe_136": "halpe136", "coco_133": "wholebody133",
    "whole_body": "wholebody133", "blazepose": "mediapipe33",
}


# ---------------------------------------------------------------------------------------------- calibrations
def _camera_spread(rig: Rig) -> float:
    centres = np.stack([c.center_mm for c in rig.cameras])
    return float(np.max(np.linalg.norm(centres - centres.mean(0), axis=-1))) if len(centres) > 1 else 0.0


def load_toml_rig(path: Path) -> Rig:
    """A Pose2Sim/aniposelib TOML calibration, in metres or (aniposelib boards measured in mm) millimetres."""
    from gaitcap.acquisition.readers import load_rig
    from gaitcap.reconstruction.calibration_io import M_TO_MM

    rig = load_rig(path)
    if _camera_spread(rig) > MM_SPREAD * M_TO_MM:
        log.warning("%s: cameras %.0f units apart: translations read as mm, not m", path, _camera_spread(rig) / 1e3)
        rig = Rig(tuple(replace(c, tvec_mm=c.tvec_mm / M_TO_MM) for c in rig.cameras))
    return rig


def read_qca(path: Path, *, binning_factor: int = 1) -> Rig:
    """A Qualisys ``.qca.txt`` calibration, converted as Pose2Sim does (sensor units / 64 -> px; the
    camera-to-world transform inverted; the camera turned by pi about its x axis); translations mm."""
    import xml.etree.ElementTree as ET

    try:
        root = ET.parse(path).getroot()
    except (OSError, ET.ParseError) as exc:
        raise ValueError(f"{path}: not a readable Qualisys calibration ({exc})") from None
    flip = np.diag([1.0, -1.0, -1.0])  # rotation by pi about x
    cams = []
    for i, tag in enumerate(root.findall("cameras/camera")):
        where = f"{path} camera {i}"
        try:
            fov, intr, tr = tag.find("fov_video"), tag.find("intrinsic"), tag.find("transform")
            size = ((int(fov.get("right")) - int(fov.get("left")) + 1) // binning_factor,
                    (int(fov.get("bottom")) - int(fov.get("top")) + 1) // binning_factor)
            scale = 64.0 * binning_factor
            k = np.array([[float(intr.get("focalLengthU")) / scale, 0.0,
                           float(intr.get("centerPointU")) / scale - float(fov.get("left"))],
                          [0.0, float(intr.get("focalLengthV")) / scale,
                           float(intr.get("centerPointV")) / scale - float(fov.get("top"))], [0.0, 0.0, 1.0]])
            dist = np.array([float(intr.get(n)) / scale for n in ("radialDistortion1", "radialDistortion2",
                                                                  "tangentalDistortion1", "tangentalDistortion2")])
            r_wc = np.array([[float(tr.get(f"r{a}{b}")) for b in "123"] for a in "123"])
            t_w = np.array([float(tr.get(a)) for a in "xyz"])
        except (AttributeError, TypeError, ValueError) as exc:
            raise ValueError(f"{where}: missing or bad field ({exc})") from None
        rot = flip @ r_wc  # Pose2Sim: transposed twice (by column, then world to camera)
        cams.append(Camera(name=tag.get("serial") or f"cam{i}", size_px=size, matrix_px=k, dist=dist,
                           rvec=matrix_to_rodrigues(rot), tvec_mm=-rot @ t_w))
    if not cams:
        raise ValueError(f"{path}: no <camera> in the Qualisys calibration")
    return Rig(tuple(sorted(cams, key=lambda c: _natural(c.name))))


def load_calibration(path: Path) -> Rig:
    """Any calibration file gaitcap reads: Qualisys ``.qca.txt``, Pose2Sim/aniposelib ``.toml`` (m or mm),
    gaitcap ``.json``."""
    from gaitcap.acquisition.readers import load_rig

    path = Path(path)
    if path.name.lower().endswith(".qca.txt"):
        return read_qca(path)
    if path.suffix.lower() == ".toml":
        return load_toml_rig(path)
    return load_rig(path)


def _natural(name: str) -> list:
    return [int(p) if p.isdigit() else p for p in re.split(r"(\d+)", name)]


# ---------------------------------------------------------------------------------------------- Pose2Sim
def _configs(folder: Path) -> list[Path]:
    """Config.toml of the folder and up to two parents (trial, participant, session), nearest first."""
    return [d / "Config.toml" for d in (folder, folder.parent, folder.parent.parent) if (d / "Config.toml").is_file()]


def is_pose2sim_folder(path: Path) -> bool:
    return path.is_dir() and (path / "pose").is_dir() and bool(_configs(path))


def pose2sim_videos(path: Path) -> Path | None:
    """The ``videos/`` folder of a Pose2Sim folder that has no 2D keypoints yet (None otherwise)."""
    ok = path.is_dir() and (path / "videos").is_dir() and not (path / "pose").is_dir() and bool(_configs(path))
    return path / "videos" if ok else None


def _setting(configs: list[Path], section: str, key: str):
    for path in configs:
        try:
            data = tomllib.loads(path.read_text())
        except tomllib.TOMLDecodeError as exc:
            raise ValueError(f"{path}: not valid TOML ({exc})") from None
        if key in data.get(section, {}):
            return data[section][key], path
    return None, None


def pose2sim_calibration(folder: Path) -> Rig | None:
    for d in (folder, folder.parent, folder.parent.parent):
        for calib in sorted(p for p in d.iterdir() if p.is_dir() and "calib" in p.name.lower()):
            tomls = sorted(calib.glob("*.toml"))
            if tomls:
                log.info("Pose2Sim calibration %s", tomls[0])
                return load_toml_rig(tomls[0])
            qcas = sorted(calib.glob("*.qca.txt"))
            if qcas:
                log.info("Pose2Sim calibration %s (Qualisys, converted)", qcas[0])
                return read_qca(qcas[0])
    return None


def read_pose2sim_folder(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    configs = _configs(path)
    model, where = _setting(configs, "pose", "pose_model")
    layout = None
    if model is not None:
        layout = POSE2SIM_MODELS.get(str(model).lower())
        if layout is None:
            raise ValueError(f"{where}: pose_model {model!r} is not supported (supported: "
                             f"{sorted(POSE2SIM_MODELS)}); convert the keypoints or name the layout with --skeleton")
    rate, _ = _setting(configs, "project", "frame_rate")
    if isinstance(rate, int | float) and rate > 0:
        fps = float(rate)
    rig = pose2sim_calibration(path)
    kp, folders, frames = openpose_people(path / "pose")
    names = match_cameras(folders, camera_names or (list(rig.names) if rig is not None else None))
    return make_input(kp, names, (frames - frames[0]) / fps, layout=layout, rig=rig,
                      source=f"Pose2Sim folder (pose_model {model or 'not set'}, {fps:g} fps)")


# ---------------------------------------------------------------------------------------------- anipose
def _anipose_calibration(path: Path) -> Path | None:
    return next((p for p in (path / "calibration.toml", path / "calibration" / "calibration.toml") if p.is_file()),
                None)


def _dlc_files(path: Path) -> list[Path]:
    """One DeepLabCut output per camera: the CSVs, else the HDF5 files anipose's pose-2d step writes."""
    folder = path / "pose-2d" if (path / "pose-2d").is_dir() else path
    return sorted(folder.glob("*.csv")) or sorted(folder.glob("*.h5"))


def is_anipose_folder(path: Path) -> bool:
    return path.is_dir() and _anipose_calibration(path) is not None and bool(_dlc_files(path))


def _normalised(name: str) -> str:
    n = re.sub(r"[^a-z0-9]", "", name.lower())
    return re.sub(r"^l(?=[a-z])(?!eft)", "left", re.sub(r"^r(?=[a-z])(?!ight)", "right", n))


def layout_of_names(names: list[str], *, where: str) -> tuple[str, list[int]]:
    """(layout, column of each of its joints) for body-part names that are a known layout's joints."""
    wanted = [_normalised(n) for n in names]
    for skel in SKELETONS.values():
        ours = [_normalised(n) for n in skel.joint_names]
        if set(ours) <= set(wanted) and len(ours) == len(set(wanted)):
            return skel.name, [wanted.index(n) for n in ours]
    raise ValueError(f"{where}: body parts {names} are not the joints of a known layout ({sorted(SKELETONS)})")


def _read_dlc_csv(path: Path) -> tuple[list[str], np.ndarray]:
    """DeepLabCut CSV -> (body-part names, (T, J, 3) x, y, likelihood)."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if len(rows) < 4 or rows[2][1:4] != ["x", "y", "likelihood"]:
        raise ValueError(f"{path}: not a DeepLabCut CSV (rows scorer, bodyparts, coords x/y/likelihood)")
    parts = rows[1][1::3]
    try:
        data = np.array([[float(v) if v else np.nan for v in r[1:1 + 3 * len(parts)]] for r in rows[3:]])
    except ValueError as exc:
        raise ValueError(f"{path}: a value is not a number ({exc})") from None
    return parts, data.reshape(len(data), len(parts), 3)


def _read_dlc_h5(path: Path) -> tuple[list[str], np.ndarray]:
    """DeepLabCut HDF5 (a pandas table, columns scorer / bodyparts / coords) -> (names, (T, J, 3))."""
    try:
        import pandas as pd
    except ImportError:
        raise ValueError(f"{path}: reading DeepLabCut .h5 files needs pandas and PyTables "
                         "(pip install 'gaitcap[anipose]'), or save the 2D poses as CSV") from None
    try:
        df = pd.read_hdf(path)
    except (ImportError, ValueError, KeyError, OSError, TypeError, RuntimeError) as exc:  # HDF5ExtError
        raise ValueError(f"{path}: not a readable DeepLabCut .h5 ({type(exc).__name__}: "
                         f"{(str(exc).strip().splitlines() or [''])[0]})") from None
    cols = df.columns
    names = list(getattr(cols, "names", []) or [])
    if "individuals" in names and cols.get_level_values("individuals").nunique() > 1:
        raise ValueError(f"{path}: a multi-animal DeepLabCut file ({cols.get_level_values('individuals').nunique()} "
                         "individuals); anipose projects track one: keep one individual per file")
    if "bodyparts" not in names or "coords" not in names:
        raise ValueError(f"{path}: not a DeepLabCut table (column levels {names}, expected bodyparts and coords)")
    parts = list(dict.fromkeys(cols.get_level_values("bodyparts")))
    coords = [str(c) for c in cols.get_level_values("coords")[:3]]
    if coords != ["x", "y", "likelihood"]:
        raise ValueError(f"{path}: coords {coords} per body part, expected x, y, likelihood")
    data = df.to_numpy(dtype=np.float64)
    return parts, data[:, : 3 * len(parts)].reshape(len(data), len(parts), 3)


_DLC_READERS = {".csv": _read_dlc_csv, ".h5": _read_dlc_h5}


def read_anipose_folder(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    rig = load_toml_rig(_anipose_calibration(path))
    files = _dlc_files(path)
    per_cam = [_DLC_READERS[f.suffix](f) for f in files]
    parts = {tuple(p) for p, _ in per_cam}
    if len(parts) > 1:
        raise ValueError(f"{path}: the camera files have different body parts")
    layout, cols = layout_of_names(list(parts.pop()), where=str(path))
    t = max(len(d) for _, d in per_cam)
    kp = np.full((len(files), t, len(cols), 3), np.nan)
    kp[..., 2] = 0.0
    for c, (_, d) in enumerate(per_cam):
        kp[c, : len(d)] = d[:, cols]
    kp[..., 2] = np.clip(np.nan_to_num(kp[..., 2]), 0.0, 1.0)
    names = match_cameras([f.stem for f in files], camera_names or list(rig.names))
    return make_input(kp, names, np.arange(t) / fps, layout=layout, rig=rig, source="anipose folder")


# ---------------------------------------------------------------------------------------------- FreeMoCap
def _freemocap_files(path: Path) -> tuple[Path | None, Path | None]:
    calib = next(iter(sorted(path.glob("*camera_calibration*.toml"))), None)
    data = next(iter(sorted(path.glob("output_data/raw_data/*2dData*.npy"))), None)
    return calib, data


def is_freemocap_folder(path: Path) -> bool:
    return path.is_dir() and all(_freemocap_files(path))


def read_freemocap_folder(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    calib, data = _freemocap_files(path)
    rig = load_toml_rig(calib)
    arr = np.load(data, allow_pickle=False)
    if arr.ndim != 4 or arr.shape[-1] not in (2, 3) or arr.shape[2] < 33:
        raise ValueError(f"{data}: expected (cameras, frames, points >= 33, 2 or 3), got {arr.shape}")
    xy = arr[:, :, :33, :2].astype(np.float64)
    conf = arr[:, :, :33, 2] if arr.shape[-1] == 3 else np.isfinite(xy).all(-1).astype(np.float64)
    kp = np.concatenate([xy, np.clip(np.nan_to_num(conf), 0, 1)[..., None]], -1)
    if len(rig.cameras) != kp.shape[0]:
        raise ValueError(f"{data}: {kp.shape[0]} cameras but the calibration {calib.name} has {len(rig.cameras)}")
    names = list(camera_names or rig.names)
    log.warning("FreeMoCap %s: cameras matched to the calibration %s by order", data.name, names)
    return make_input(kp, names, np.arange(kp.shape[1]) / fps, layout="mediapipe33", rig=rig,
                      source="FreeMoCap recording folder")
