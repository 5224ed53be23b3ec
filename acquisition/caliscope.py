"""caliscope sessions: its ChArUco corner detections (``xy*.csv``), its board (``charuco.toml``) and its
calibration (``camera_array.toml``), read into gaitcap's types.

This lets a rig calibrated with caliscope be calibrated again here from the same detections, and
gaitcap's calibration be compared with caliscope's on a real recording. The detections' cameras are
paired by their frame times (``frame_time``, s) like any other unsynchronised recording; a file without
frame times is paired by caliscope's ``sync_index``.
"""

from __future__ import annotations

import csv
import os
import tomllib
from pathlib import Path

import numpy as np
from gaitcap.acquisition.board import BoardConfig, make_board
from gaitcap.acquisition.board_pairing import (
    MISSING,
    PairingConfig,
    default_tolerance_ns,
    pair_by_time,
    separate_moving,
)
from gaitcap.reconstruction.calibration import BoardObservations
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues

CAMERA_PREFIX = "cam_"
SESSION_POINTS = "calibration/extrinsic/xy.csv"


def is_session(folder: str | os.PathLike) -> bool:
    """A caliscope session folder with a board, a calibration and extrinsic corner detections."""
    folder = Path(folder)
    return all((folder / f).is_file() for f in ("charuco.toml", "camera_array.toml", SESSION_POINTS))


def is_camera_array(path: str | os.PathLike) -> bool:
    """caliscope's ``camera_array.toml`` (cameras under ``[cameras.<id>]``)."""
    path = Path(path)
    if path.suffix.lower() != ".toml" or not path.is_file():
        return False
    with open(path, "rb") as f:
        cameras = tomllib.load(f).get("cameras")
    return isinstance(cameras, dict) and all(k.isdigit() and isinstance(v, dict) for k, v in cameras.items())


def camera_name(cam_id: int | str) -> str:
    return f"{CAMERA_PREFIX}{int(cam_id)}"


def read_camera_array(path: str | os.PathLike) -> Rig:
    """caliscope's ``camera_array.toml`` as a Rig (translations m -> mm; rotation as a matrix or a
    Rodrigues vector, world -> camera). Cameras marked ``ignore`` or without extrinsics are left out."""
    path = Path(path)
    with open(path, "rb") as f:
        cameras = tomllib.load(f).get("cameras", {})
    out = []
    for key, cam in sorted(cameras.items(), key=lambda kv: int(kv[0])):
        if cam.get("ignore") or cam.get("rotation") is None or cam.get("translation") is None:
            continue
        rot = np.asarray(cam["rotation"], dtype=np.float64)
        rvec = rot.reshape(3) if rot.size == 3 else matrix_to_rodrigues(rot.reshape(3, 3))
        dist = np.asarray(cam["distortions"], dtype=np.float64).ravel()
        out.append(Camera(camera_name(key), tuple(int(v) for v in cam["size"]), np.asarray(cam["matrix"], float),
                          np.pad(dist, (0, 5 - dist.size)), np.asarray(rvec, float),
                          1000.0 * np.asarray(cam["translation"], dtype=np.float64), ""))
    if not out:
        raise ValueError(f"{path}: no calibrated cameras in it")
    return Rig(tuple(out))


def _rows(path: Path) -> list[dict[str, str]]:
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    need = {"sync_index", "cam_id", "point_id", "img_loc_x", "img_loc_y"}
    if not rows or not need <= rows[0].keys():
        raise ValueError(f"{path}: not a caliscope points file (needs columns {sorted(need)})")
    return rows


def read_points(
    path: str | os.PathLike, *, board: BoardConfig, image_sizes_px: dict[str, tuple[int, int]],
    pairing: PairingConfig = PairingConfig(),
) -> tuple[BoardObservations, int]:
    """caliscope ChArUco corners as BoardObservations, and how many views were taken out of their frame
    sets (kept as frames of their own) because the board moved between the cameras' exposures, plus
    those left out because it moved during the readout (``pairing.readout_ms``).

    image_sizes_px: {camera: (width, height)} (caliscope keeps them in camera_array.toml).
    """
    path = Path(path)
    rows = _rows(path)
    geometry = make_board(board).geometry
    cams = sorted({int(r["cam_id"]) for r in rows})
    names = [camera_name(c) for c in cams]
    missing = [n for n in names if n not in image_sizes_px]
    if missing:
        raise ValueError(f"{path}: no image size given for cameras {missing}")
    timed = "frame_time" in rows[0]
    # one frame per (camera, caliscope frame): its time and its corners
    frames: dict[tuple[int, int], dict] = {}
    for r in rows:
        c = cams.index(int(r["cam_id"]))
        key = (c, int(r.get("frame_index") or r["sync_index"]))
        frame = frames.setdefault(key, {"t": float(r["frame_time"]) if timed else float(r["sync_index"]),
                                        "sync": int(r["sync_index"]), "uv": {}})
        pid = int(r["point_id"])
        if not 0 <= pid < geometry.num_corners:
            raise ValueError(f"{path}: point_id {pid} is not a corner of {geometry.name}")
        frame["uv"][pid] = (float(r["img_loc_x"]), float(r["img_loc_y"]))
    per_cam = [sorted((k[1], v) for k, v in frames.items() if k[0] == c) for c in range(len(cams))]
    if timed:
        times = [np.rint(np.array([v["t"] for _, v in fr]) * 1e9).astype(np.int64) for fr in per_cam]
        tol = int(pairing.tolerance_ms * 1e6) if pairing.tolerance_ms is not None else default_tolerance_ns(times)
        sets = pair_by_time(times, min(tol, _half_gap_ns(per_cam)))
    else:
        sets = pair_by_time([np.array([v["sync"] for _, v in fr], dtype=np.int64) for fr in per_cam], 0)
    corners = np.full((len(cams), len(sets), geometry.num_corners, 2), np.nan)
    cam_t = np.full((len(cams), len(sets)), np.nan)
    for s, members in enumerate(sets):
        for c, i in enumerate(members):
            if i == MISSING:
                continue
            frame = per_cam[c][i][1]
            for pid, uv in frame["uv"].items():
                corners[c, s, pid] = uv
            cam_t[c, s] = frame["t"]
    set_t = np.nanmedian(cam_t, axis=0)
    corners, times_s, moving, smeared = separate_moving(corners, cam_t, set_t - set_t.min(), pairing, timed=timed)
    obs = BoardObservations(tuple(names), tuple(tuple(image_sizes_px[n]) for n in names), corners, geometry,
                            times_s)
    return obs, int(moving.sum() + smeared.sum())


def _half_gap_ns(per_cam: list[list]) -> int:
    """Half the smallest gap between two of one camera's detected frames (caliscope keeps every n-th
    frame, so the frame interval is unknown: pairs must not reach a camera's next detection)."""
    gaps = [np.diff(sorted(v["t"] for _, v in fr)) for fr in per_cam if len(fr) > 1]
    gaps = np.concatenate(gaps) if gaps else np.zeros(0)
    gaps = gaps[gaps > 0]
    return max(1, int(gaps.min() * 1e9 // 2)) if gaps.size else 1


def read_session(folder: str | os.PathLike, points: str = SESSION_POINTS,
                 pairing: PairingConfig = PairingConfig(), board: BoardConfig | None = None,
                 ) -> tuple[BoardConfig, BoardObservations, Rig, int]:
    """A caliscope session folder: (board, observations, caliscope's calibration, views left out moving);
    the board from its ``charuco.toml`` unless given."""
    from gaitcap.acquisition.board_file import read_board_file

    folder = Path(folder)
    board = board or read_board_file(folder / "charuco.toml")
    rig = read_camera_array(folder / "camera_array.toml")
    obs, moving = read_points(folder / points, board=board, pairing=pairing,
                              image_sizes_px={c.name: c.size_px for c in rig.cameras})
    return board, obs, rig, moving

