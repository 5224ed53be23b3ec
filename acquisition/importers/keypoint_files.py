"""Keypoints from files and other tools' folders -> :class:`KeypointInput` (everyone's 2D keypoints, the
layout when the input says it, and the calibration when the input carries one).

Supported inputs (:func:`read_keypoints_input` asks each :class:`Reader` in turn whether it accepts the path):

- NPZ (read by :func:`gaitcap.acquisition.readers.read_keypoint_arrays`): ``keypoints`` (C, T, J, 3) x px,
  y px, confidence, or (C, T, P, J, 3) with several people; ``camera_names`` (or ``cameras``) (C,) names;
  optional ``times_s`` (T,) and ``skeleton`` (layout name).
- A trial MCAP written by the recorder (layout and calibration recorded in it).
- Other tools' folders (:mod:`gaitcap.acquisition.importers.tool_folders`): a Pose2Sim project or trial folder
  (``Config.toml`` ``pose_model``, ``calibration/`` TOML or Qualisys ``.qca.txt``, ``pose/`` OpenPose
  JSON), an anipose/aniposelib folder (``calibration.toml`` + DeepLabCut CSV per camera), a FreeMoCap
  recording folder (``*_camera_calibration.toml`` + ``mediapipe_2dData...npy``).
- MMPose/RTMLib JSON (:mod:`gaitcap.acquisition.importers.mmpose_json`): a ``.json`` file or a folder of them, one
  per camera (camera = file stem).
- A folder with one sub-folder of OpenPose-format JSON files per camera (what OpenPose writes): one file
  per frame, ``people[i].pose_keypoints_2d`` = J x (x, y, confidence); frames matched across cameras by
  the number in the file name.

Cameras are matched to the calibration by name (the sub-folder or file name equals, starts with, ends with
or contains the camera name, ignoring case and punctuation); by order only when names do not match, with a
logged warning. People are
kept, most confident first in every camera frame; who the patient is is decided downstream
(:mod:`gaitcap.services.processing.pipeline`).
"""

from __future__ import annotations

import logging
from collections.abc import Callable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
from gaitcap.acquisition.importers import mmpose_json, tool_folders
from gaitcap.acquisition.importers.keypoint_input import (
    KeypointInput,
    make_input,
    match_cameras,
    provisional_skeleton,
)
from gaitcap.acquisition.importers.openpose_json import openpose_people
from gaitcap.acquisition.readers import read_keypoint_arrays
from gaitcap.reconstruction.camera import Rig

log = logging.getLogger(__name__)

DEFAULT_FPS = 30.0


# ---------------------------------------------------------------------------------------------- NPZ
def read_npz(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    """A keypoint NPZ (:func:`gaitcap.acquisition.readers.read_keypoint_arrays`); without ``times_s`` the frames
    are ``fps`` apart, without ``skeleton`` the layout is recognised later. Checked as the loaders check
    (:class:`~gaitcap.reconstruction.keypoints.MultiViewKeypoints`: confidences in 0..1, times increasing,
    camera names distinct), errors naming the file."""
    kp, names, times, layout = read_keypoint_arrays(path, optional=("times_s", "skeleton"))
    times = np.arange(kp.shape[1]) / fps if times is None else times
    try:
        return make_input(kp, names, times, layout=layout, rig=None, source="keypoints NPZ")
    except ValueError as exc:
        raise ValueError(f"{path}: {exc}") from None


def read_mcap(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    from gaitcap.acquisition.recording.reader import read_calibration, read_keypoints

    rec = read_keypoints(path, camera_names)
    try:
        rig = read_calibration(path)
    except (ValueError, KeyError):
        rig = None
    return KeypointInput(rec, rec.skeleton.name, rig, "trial MCAP")


# ---------------------------------------------------------------------------------------------- OpenPose
def read_openpose_folder(path: Path, *, fps: float, camera_names: list[str] | None = None) -> KeypointInput:
    kp, folders, frames = openpose_people(path)
    names = match_cameras(folders, camera_names)
    return make_input(kp, names, (frames - frames[0]) / fps, layout=None, rig=None, source="OpenPose JSON folder")


# ---------------------------------------------------------------------------------------------- dispatch
@dataclass(frozen=True)
class Reader:
    """An input kind: ``accepts(path)`` says whether it is one; ``read(path, fps=, camera_names=)``."""

    name: str
    accepts: Callable[[Path], bool]
    read: Callable[..., KeypointInput]


def _suffix(*suffixes: str) -> Callable[[Path], bool]:
    return lambda p: p.is_file() and p.suffix.lower() in suffixes


def _readers() -> tuple[Reader, ...]:
    return (
        Reader("npz", _suffix(".npz"), read_npz),
        Reader("mcap", _suffix(".mcap"), read_mcap),
        Reader("pose2sim", tool_folders.is_pose2sim_folder, tool_folders.read_pose2sim_folder),
        Reader("anipose", tool_folders.is_anipose_folder, tool_folders.read_anipose_folder),
        Reader("freemocap", tool_folders.is_freemocap_folder, tool_folders.read_freemocap_folder),
        Reader("mmpose", mmpose_json.is_mmpose_input, mmpose_json.read_mmpose_input),
        Reader("openpose", lambda p: p.is_dir(), read_openpose_folder),
    )


def read_keypoints_input(
    path: str | Path, *, rig: Rig | None = None, fps: float = DEFAULT_FPS, skeleton: str | None = None
) -> KeypointInput:
    """Everyone's keypoints from any supported input (see the module docstring). ``rig``: a calibration
    given by the user (its camera names are matched to the input's); ``skeleton``: the layout named by
    the user, which wins over the input's own."""
    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"keypoints input {path} does not exist")
    reader = next((r for r in _readers() if r.accepts(path)), None)
    if reader is None:
        raise ValueError(f"keypoints input {path}: expected a .npz file, a .mcap trial, an MMPose .json file or a "
                         "folder (Pose2Sim, anipose, FreeMoCap, MMPose JSON or OpenPose JSON)")
    data = reader.read(path, fps=fps, camera_names=list(rig.names) if rig is not None else None)
    log.info("%s: read as a %s (%d cameras, %d frames, up to %d people)", path, data.source,
             *data.recording.shape[:3])
    if skeleton:
        rec = data.recording
        name = provisional_skeleton(rec.shape[-1], skeleton)
        rec = replace(rec, skeleton=name)
        data = KeypointInput(rec, name, data.rig, data.source)
    return data
