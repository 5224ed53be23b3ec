"""caliscope sessions: its ChArUco corner detections (``xy*.csv``), its board (``charuco.toml``) and its
calibration (``camera_array.toml``), read into gaitcap's types.

This lets a rig calibrated with caliscope be calibrated again here from the same detections, and
gaitcap's calibration be compared with caliscope's on a real recording. The detections' cameras are
paired by their frame times (``frame_time``, s) like any other unsynchronised recording; a file without
usable frame times (no column, empty, or not increasing within a camera, e.g. all 0.0) is paired by
caliscope's ``sync_index``. Two layouts: ``calibration/extrinsic/xy.csv`` and the tracker-named
``calibration/extrinsic/<TRACKER>/xy_<TRACKER>.csv`` (``CHARUCO``); cameras in a ``cam_id`` column (older
files: ``port``).
"""

from __future__ import annotations

import csv
import logging
import os
import tomllib
from pathlib import Path

import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.boards.pairing import (
    MISSING,
    PairingConfig,
    default_tolerance_ns,
    pair_by_time,
    separate_moving,
)
from gaitcap.reconstruction.calibration import BoardObservations
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues

log = logging.getLogger(__name__)

CAMERA_PREFIX = "cam_"
SESSION_POINTS = ("calibration/extrinsic/xy.csv", "calibration/extrinsic/CHARUCO/xy_CHARUCO.csv")
CAMERA_COLUMNS = ("cam_id", "port")  # caliscope's camera column, and its older name


def session_points(folder: str | os.PathLike) -> Path | None:
    """The session's extrinsic ChArUco detections (the first of :data:`SESSION_POINTS` there), or None."""
    found = [Path(folder) / p for p in SESSION_POINTS if (Path(folder) / p).is_file()]
    return found[0] if found else None


def is_session(folder: str | os.PathLike) -> bool:
    """A caliscope session folder with a board, a calibration and extrinsic corner detections."""
    folder = Path(folder)
    return all((folder / f).is_file() for f in ("charuco.toml", "camera_array.toml")) and \
        session_points(folder) is not None


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


def _columns(path: Path, header: list[str]) -> dict[str, str | None]:
    """The file's column for each field gaitcap reads (None: optional and absent)."""
    camera = next((c for c in CAMERA_COLUMNS if c in header), None)
    need = ["sync_index", "point_id", "img_loc_x", "img_loc_y"]
    missing = [c for c in need if c not in header] + ([" or ".join(CAMERA_COLUMNS)] if camera is None else [])
    if missing:
        raise ValueError(f"{path}: not a caliscope points file: no column {', '.join(missing)} "
                         f"(has {header})")
    board_loc = next((p for p in ("obj_loc", "board_loc") if f"{p}_x" in header and f"{p}_y" in header), None)
    return {**{c: c for c in need}, "cam": camera,
            "frame": "frame_index" if "frame_index" in header else None,
            "time": "frame_time" if "frame_time" in header else None, "board_loc": board_loc}


def _number(path: Path, line: int, column: str, text: str | None, kind: type) -> float | int | None:
    try:
        return kind(text)
    except (TypeError, ValueError):
        raise ValueError(f"{path} line {line}, column {column}: {text!r} is not a number") from None


def _rows(path: Path, sync_every: int = 1) -> tuple[list[tuple], bool, dict[int, tuple[float, float]]]:
    """The detections as (camera, frame, sync_index, time s or None, point_id, x px, y px) rows of the
    sync indices kept (every ``sync_every``-th), whether their frame times are present, and each corner's
    position on the board (from ``obj_loc_x/y`` or ``board_loc_x/y``, m -> mm) where the file has it."""
    with open(path, newline="") as f:
        reader = csv.reader(f)
        header = next(reader, [])
        cols = _columns(path, header)
        at = {k: header.index(v) for k, v in cols.items() if v is not None and k != "board_loc"}
        loc = cols["board_loc"]
        loc_at = (header.index(f"{loc}_x"), header.index(f"{loc}_y")) if loc else None
        out, board_mm = [], {}
        for line, r in enumerate(reader, start=2):
            if len(r) != len(header):
                raise ValueError(f"{path} line {line}: {len(r)} fields, the header has {len(header)}")
            sync = _number(path, line, cols["sync_index"], r[at["sync_index"]], int)
            if sync % sync_every:
                continue
            frame = _number(path, line, cols["frame"], r[at["frame"]], int) if "frame" in at else sync
            text = r[at["time"]] if "time" in at else ""
            t = _number(path, line, cols["time"], text, float) if text.strip() else None
            pid = _number(path, line, "point_id", r[at["point_id"]], int)
            out.append((_number(path, line, cols["cam"], r[at["cam"]], int), frame, sync, t, pid,
                        _number(path, line, "img_loc_x", r[at["img_loc_x"]], float),
                        _number(path, line, "img_loc_y", r[at["img_loc_y"]], float)))
            if loc_at and pid not in board_mm:
                board_mm[pid] = tuple(1000.0 * _number(path, line, f"{loc}_{a}", r[i], float)
                                      for a, i in zip("xy", loc_at, strict=True))
    if not out:
        kept = f" (every {sync_every}th sync_index)" if sync_every > 1 else ""
        raise ValueError(f"{path}: no detections in it{kept}")
    timed = all(r[3] is not None for r in out)
    return out, timed, board_mm


def _check_board(path: Path, board_mm: dict[int, tuple[float, float]], geometry, tol_mm: float = 0.5) -> None:
    """The board the detections were made with (its corners' positions in the file) must be the board
    described: the same distances between corners, within ``tol_mm``."""
    ids = sorted(board_mm)
    if len(ids) < 2:
        return
    if ids[-1] >= geometry.num_corners:
        raise ValueError(f"{path}: point_id {ids[-1]} is not a corner of {geometry.name}")
    theirs = np.array([board_mm[i] for i in ids])
    ours = geometry.object_points_mm[ids, :2]
    d_theirs = np.linalg.norm(theirs[:, None] - theirs[None], axis=-1)
    d_ours = np.linalg.norm(ours[:, None] - ours[None], axis=-1)
    worst = float(np.abs(d_theirs - d_ours).max())
    if worst > tol_mm:
        ratio = float(np.median(d_theirs[d_ours > 0] / d_ours[d_ours > 0]))
        raise ValueError(f"{path}: the corners' board positions (columns *_loc_x, *_loc_y) are not those of "
                         f"{geometry.name}: distances differ by up to {worst:.1f} mm (theirs {ratio:.3f} x "
                         "ours): the board description does not match the board detected")


def _times_usable(rows: list[tuple]) -> bool:
    """Frame times that pair cameras: present, and increasing with each camera's frame index."""
    by_frame = {(r[0], r[1]): r[3] for r in rows}
    for cam in {k[0] for k in by_frame}:
        t = np.array([by_frame[k] for k in sorted(k for k in by_frame if k[0] == cam)])
        if t.size > 1 and not np.all(np.diff(t) > 0):
            return False
    return True


def read_points(
    path: str | os.PathLike, *, board: BoardConfig, image_sizes_px: dict[str, tuple[int, int]],
    pairing: PairingConfig = PairingConfig(), sync_every: int = 1,
) -> tuple[BoardObservations, int]:
    """caliscope ChArUco corners as BoardObservations, and how many views were taken out of their frame
    sets (kept as frames of their own) because the board moved between the cameras' exposures, plus
    those left out because it moved during the readout (``pairing.readout_ms``).

    image_sizes_px: {camera: (width, height)} (caliscope keeps them in camera_array.toml).
    sync_every: keep only every N-th ``sync_index`` (0, N, 2N, ...), as caliscope's own tests thin it.
    """
    path = Path(path)
    if sync_every < 1:
        raise ValueError(f"sync_every must be >= 1, got {sync_every}")
    rows, timed, board_mm = _rows(path, sync_every)
    geometry = make_board(board).geometry
    _check_board(path, board_mm, geometry)
    timed = timed and _times_usable(rows)
    if not timed:
        asked = [f"{name} {value:g} ms" for name, value in (("readout_ms", pairing.readout_ms),
                                                              ("tolerance_ms", pairing.tolerance_ms)) if value]
        if asked:  # they would be ignored: say so rather than pair without them
            raise ValueError(f"{path}: no usable frame_time (missing, empty or not increasing in a camera): the "
                             f"cameras are paired by sync_index and the board's motion in time is unknown, so "
                             f"{' and '.join(asked)} cannot apply")
        log.info("%s: no usable frame_time: cameras paired by sync_index", path)
    cams = sorted({r[0] for r in rows})
    names = [camera_name(c) for c in cams]
    missing = [n for n in names if n not in image_sizes_px]
    if missing:
        raise ValueError(f"{path}: no image size given for cameras {missing}")
    index = {c: i for i, c in enumerate(cams)}
    # one frame per (camera, caliscope frame): its time and its corners
    frames: dict[tuple[int, int], dict] = {}
    for cam, frame_index, sync, t, pid, x, y in rows:
        frame = frames.setdefault((index[cam], frame_index),
                                  {"t": t if timed else float(sync), "sync": sync, "uv": {}})
        if not 0 <= pid < geometry.num_corners:
            raise ValueError(f"{path}: point_id {pid} is not a corner of {geometry.name}")
        frame["uv"][pid] = (x, y)
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


def read_session(folder: str | os.PathLike, points: str | None = None,
                 pairing: PairingConfig = PairingConfig(), board: BoardConfig | None = None,
                 sync_every: int = 1) -> tuple[BoardConfig, BoardObservations, Rig, int]:
    """A caliscope session folder: (board, observations, caliscope's calibration, views left out moving);
    the board from its ``charuco.toml`` unless given; the detections from ``points`` (a path in the
    folder; default: the one of :data:`SESSION_POINTS` it has), every ``sync_every``-th sync index."""
    from gaitcap.acquisition.boards.file import read_board_file

    folder = Path(folder)
    path = folder / points if points is not None else session_points(folder)
    if path is None:
        raise ValueError(f"{folder}: no caliscope corner detections in it "
                         f"(looked for {', '.join(SESSION_POINTS)})")
    board = board or read_board_file(folder / "charuco.toml")
    rig = read_camera_array(folder / "camera_array.toml")
    obs, moving = read_points(path, board=board, pairing=pairing, sync_every=sync_every,
                              image_sizes_px={c.name: c.size_px for c in rig.cameras})
    return board, obs, rig, moving



# caliscope's own calibration, run here through its scripting API (caliscope >= 0.11; the optional extra
# ``gaitcap[caliscope]``), so that it can be fitted on exactly the frame sets a gaitcap calibration is
# fitted on (each fold of the held-out error) instead of being judged on views it was made from.
CALISCOPE_API_VERSION = "0.11.8"  # the version measured (pyproject.toml's extra pins it)


def caliscope_available() -> bool:
    """Whether caliscope's scripting API can be imported (the optional extra ``gaitcap[caliscope]``)."""
    try:
        import caliscope.api  # noqa: F401
    except ImportError:
        return False
    return True


def _caliscope_api():
    try:
        import caliscope.api as api
    except ImportError as exc:
        raise ValueError(f"caliscope's calibration needs caliscope {CALISCOPE_API_VERSION} (its scripting API): "
                         "pip install -e '.[caliscope]' in gaitcap's checkout") from exc
    return api


def image_points_frame(obs: BoardObservations):
    """The observations as caliscope's ImagePoints table (pandas): one row per corner seen, ``sync_index``
    the frame set, ``cam_id`` the camera's position in ``obs``, ``keypoint_id`` the corner id, ``obj_loc``
    its position on the board (m), ``frame_time`` the frame set's time (s)."""
    import pandas as pd

    c, f, n = np.nonzero(np.all(np.isfinite(obs.corners_px), -1))
    board_m = obs.board.object_points_mm / 1000.0
    return pd.DataFrame({
        "sync_index": f.astype(np.int64), "cam_id": c.astype(np.int64), "frame_time": obs.times_s[f],
        "object_id": np.zeros(len(c), dtype=np.int64), "keypoint_id": n.astype(np.int64),
        "img_loc_x": obs.corners_px[c, f, n, 0], "img_loc_y": obs.corners_px[c, f, n, 1],
        "obj_loc_x": board_m[n, 0], "obj_loc_y": board_m[n, 1], "obj_loc_z": board_m[n, 2]})


def rig_from_camera_array(array, names: tuple[str, ...] | list[str]) -> Rig:
    """caliscope's CameraArray (cameras by their position in ``names``; rotation world -> camera, metres)
    as a Rig named ``names`` (ValueError naming the cameras it left unposed)."""
    unposed = [n for c, n in enumerate(names) if c not in array.cameras or array.cameras[c].rotation is None
               or array.cameras[c].translation is None]
    if unposed:
        raise ValueError(f"caliscope's calibration left cameras {unposed} without a pose")
    out = []
    for c, name in enumerate(names):
        cam = array.cameras[c]
        dist = np.asarray(cam.distortions, dtype=np.float64).ravel()
        out.append(Camera(name, tuple(int(v) for v in cam.size), np.asarray(cam.matrix, dtype=np.float64),
                          np.pad(dist, (0, 5 - dist.size)), matrix_to_rodrigues(np.asarray(cam.rotation, float)),
                          1000.0 * np.asarray(cam.translation, dtype=np.float64).ravel(), ""))
    return Rig(tuple(out))


def calibrate_with_caliscope(obs: BoardObservations, intrinsics: Rig | None = None) -> Rig:
    """caliscope's own calibration of these board observations, through its scripting API.

    intrinsics: a calibration whose cameras' K and distortion caliscope starts from (caliscope's
    ``camera_array.toml``, whose intrinsics come from its separate intrinsics session), as its extrinsic
    calibration does (``calibrate_extrinsics``: poses bootstrapped from camera pairs, then its bundle
    adjustment; it refines focal length, k1 and k2 only where its depth-ratio gate allows). None: each
    camera's intrinsics from these views first (caliscope's ``calibrate_intrinsics``: its frame selection
    and OpenCV's five-term model), as caliscope would calibrate from this clip alone.
    ValueError with caliscope's message when it cannot calibrate them (or is not installed)."""
    api = _caliscope_api()
    points = api.ImagePoints(image_points_frame(obs))
    cameras = {}
    for c, (name, size) in enumerate(zip(obs.camera_names, obs.image_sizes_px, strict=True)):
        size = (int(size[0]), int(size[1]))
        if intrinsics is None:
            try:
                cameras[c] = api.calibrate_intrinsics(points, api.CameraData(cam_id=c, size=size)).camera
            except api.CalibrationError as exc:
                raise ValueError(f"caliscope's intrinsic calibration of {name}: {exc}") from exc
            continue
        if name not in intrinsics.names:
            raise ValueError(f"caliscope's calibration: no intrinsics given for camera {name} "
                             f"(given: {list(intrinsics.names)})")
        given = intrinsics[name]
        cameras[c] = api.CameraData(cam_id=c, size=size, matrix=np.array(given.matrix_px, dtype=np.float64),
                                    distortions=np.array(given.dist, dtype=np.float64))
    try:
        run = api.calibrate_extrinsics(points, api.CameraArray(cameras), None)
    except (api.CalibrationError, ValueError, np.linalg.LinAlgError) as exc:
        raise ValueError(f"caliscope's extrinsic calibration: {exc}") from exc
    return rig_from_camera_array(run.capture_volume.camera_array, obs.camera_names)
