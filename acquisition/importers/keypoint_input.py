"""Everyone's 2D keypoints read from an input: the type every keypoint reader returns
(:class:`KeypointInput`) and what readers share (people ordering, camera-name matching)."""

from __future__ import annotations

import logging
import re
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import get_skeleton

log = logging.getLogger(__name__)


@dataclass(frozen=True, eq=False)
class KeypointInput:
    """Everyone's keypoints read from an input.

    Attributes:
        recording: everyone's keypoints (most confident first per camera frame); its ``skeleton`` is
            provisional when ``layout`` is None.
        layout: the layout the input names (file metadata, the tool's config, ``--skeleton``), or None
            when it has to be recognised from the keypoints.
        rig: the calibration the input carries (trial MCAP, tool folders), or None.
        source: what was read (words, for messages).
    """

    recording: MultiViewKeypoints
    layout: str | None
    rig: Rig | None
    source: str


def sort_people(people: np.ndarray) -> np.ndarray:
    """(C, T, P, J, 3) with, per camera frame, people by decreasing mean confidence (NaN counts 0)."""
    if people.shape[2] <= 1:
        return people
    order = np.argsort(-np.nan_to_num(people[..., 2]).mean(-1), axis=-1, kind="stable")  # (C, T, P)
    return np.take_along_axis(people, order[..., None, None], axis=2)


def provisional_skeleton(num_joints: int, layout: str | None) -> str:
    """``layout`` when given (checked), else the first registered layout with ``num_joints`` keypoints."""
    from gaitcap.reconstruction.layout_guess import candidate_layouts

    if layout:
        skel = get_skeleton(layout)
        if skel.num_joints != num_joints:
            raise ValueError(f"skeleton {skel.name} has {skel.num_joints} keypoints but the input has {num_joints}")
        return skel.name
    return candidate_layouts(num_joints)[0].name


def make_input(people, camera_names, times_s, *, layout: str | None, rig: Rig | None, source: str) -> KeypointInput:
    """File keypoints (C, T, J, 3) or (C, T, P, J, 3) as input, most confident first per camera frame
    (frame ids 0..T-1, timestamps from ``times_s``, every frame live); ValueError naming the field that is
    wrong."""
    people = np.asarray(people, dtype=np.float64)
    if people.ndim == 4:
        people = people[:, :, None]
    if people.ndim != 5 or people.shape[-1] != 3:
        raise ValueError(f"keypoints: expected shape (C, T, J, 3) or (C, T, P, J, 3), got {people.shape}")
    skel = provisional_skeleton(people.shape[-2], layout)
    keypoints = MultiViewKeypoints(sort_people(people), tuple(str(n) for n in camera_names), times_s, skel)
    return KeypointInput(keypoints, layout and skel, rig, source)


def match_cameras(folders: list[str], camera_names: list[str] | None) -> list[str]:
    """Camera name for each sub-folder or file: by name when every one matches a different camera,
    else by order (logged as a warning)."""
    if not camera_names:
        return list(folders)

    def plain(name: str) -> str:  # "cam_01" and "cam01_json" compare as "cam01", "cam01json"
        return re.sub(r"[^a-z0-9]", "", name.lower())

    def match(folder: str) -> str | None:
        f = plain(folder)
        hits = [c for c in camera_names if f == plain(c)]
        hits = hits or [c for c in camera_names if f.startswith(plain(c))]
        hits = hits or [c for c in camera_names if f.endswith(plain(c))]  # anipose: "walk-camA" is camera "A"
        hits = hits or [c for c in camera_names if plain(c) in f]
        return max(hits, key=len) if hits else None

    named = [match(f) for f in folders]
    if all(named) and len(set(named)) == len(named):
        return named  # type: ignore[return-value]
    if len(folders) == len(camera_names):
        log.warning("cameras %s do not match the calibration's names %s: matched by order", folders,
                    list(camera_names))
        return list(camera_names)
    raise ValueError(
        f"camera folders {folders} match neither the calibration's camera names {camera_names} nor their number"
    )
