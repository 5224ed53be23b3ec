"""Calibration files: the aniposelib / Pose2Sim TOML format and gaitcap's own JSON format.

TOML (aniposelib / Pose2Sim)::

    [cam_0]
    name = "cam01"
    size = [1920.0, 1200.0]          # width, height px
    matrix = [[fx, 0, cx], [0, fy, cy], [0, 0, 1]]
    distortions = [k1, k2, p1, p2]   # 4 or 5 OpenCV coefficients
    rotation = [rx, ry, rz]          # Rodrigues, world -> camera
    translation = [tx, ty, tz]       # METRES
    fisheye = false

    [metadata]
    adjusted = false
    error = 0.0

gaitcap JSON::

    {"format": "gaitcap-calibration", "version": 1, "units": {"translation": "mm"},
     "cameras": [{"name", "serial", "size_px", "matrix_px", "dist", "rvec", "rotation_matrix"?, "tvec_mm"}]}

Parsers raise ValueError naming the file, the camera section and the field that is wrong.
"""

from __future__ import annotations

import json
import tomllib
from typing import Any

import numpy as np
import tomli_w
from gaitcap.reconstruction.camera import Camera, Rig, check_rotation, matrix_to_rodrigues

JSON_FORMAT = "gaitcap-calibration"
JSON_VERSION = 1
M_TO_MM = 1000.0


def _field(section: dict[str, Any], key: str, *, where: str) -> Any:
    if key not in section:
        raise ValueError(f"{where}: missing field {key!r}")
    return section[key]


def _array(value: Any, shape: tuple[int, ...] | None, *, where: str, key: str) -> np.ndarray:
    try:
        arr = np.asarray(value, dtype=np.float64)
    except (TypeError, ValueError) as exc:
        raise ValueError(f"{where}: field {key!r} is not numeric ({exc})") from None
    if shape is not None and arr.shape != shape:
        raise ValueError(f"{where}: field {key!r} has shape {arr.shape}, expected {shape}")
    if not np.all(np.isfinite(arr)):
        raise ValueError(f"{where}: field {key!r} contains NaN or infinite values")
    return arr


def _rotation_to_rvec(value: Any, *, where: str, key: str) -> np.ndarray:
    """Accept a Rodrigues vector (3,) or a rotation matrix (3, 3)."""
    arr = _array(value, None, where=where, key=key)
    if arr.shape == (3,):
        return arr
    if arr.shape == (3, 3):
        check_rotation(arr, what=f"{where}: field {key!r}")
        return matrix_to_rodrigues(arr)
    raise ValueError(f"{where}: field {key!r} has shape {arr.shape}, expected (3,) Rodrigues or (3, 3) matrix")


def _camera_from_toml(section: dict[str, Any], *, where: str) -> Camera:
    if _field(section, "fisheye", where=where) if "fisheye" in section else False:
        raise ValueError(f"{where}: fisheye cameras are not supported (field 'fisheye' = true)")
    size = _array(_field(section, "size", where=where), (2,), where=where, key="size")
    dist = _array(_field(section, "distortions", where=where), None, where=where, key="distortions").reshape(-1)
    if not 1 <= dist.size <= 5:
        raise ValueError(f"{where}: field 'distortions' has {dist.size} values, expected 1 to 5")
    try:
        return Camera(
            name=str(_field(section, "name", where=where)),
            size_px=(int(size[0]), int(size[1])),
            matrix_px=_array(_field(section, "matrix", where=where), (3, 3), where=where, key="matrix"),
            dist=dist,
            rvec=_rotation_to_rvec(_field(section, "rotation", where=where), where=where, key="rotation"),
            tvec_mm=_array(_field(section, "translation", where=where), (3,), where=where, key="translation")
            * M_TO_MM,
            serial=str(section.get("serial", "")),
        )
    except ValueError as exc:
        raise ValueError(f"{where}: {exc}") from None


def rig_from_toml_text(text: str, *, source: str = "<toml>") -> Rig:
    """Parse aniposelib/Pose2Sim TOML text into a Rig (translations converted m -> mm)."""
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        raise ValueError(f"{source}: not valid TOML ({exc})") from None
    sections = [(k, v) for k, v in data.items() if k != "metadata" and isinstance(v, dict)]
    if not sections:
        raise ValueError(f"{source}: no camera sections ([cam_0], ...) found")
    cams = [_camera_from_toml(v, where=f"{source} [{k}]") for k, v in sections]
    return Rig(tuple(cams))


def rig_to_toml_text(rig: Rig, *, metadata: dict[str, Any] | None = None) -> str:
    """Serialise a Rig to aniposelib/Pose2Sim TOML (translations in metres)."""
    data: dict[str, Any] = {}
    for i, cam in enumerate(rig):
        data[f"cam_{i}"] = {
            "name": cam.name,
            "size": [float(cam.size_px[0]), float(cam.size_px[1])],
            "matrix": cam.matrix_px.tolist(),
            "distortions": cam.dist.tolist(),
            "rotation": cam.rvec.tolist(),
            "translation": (cam.tvec_mm / M_TO_MM).tolist(),
            "fisheye": False,
        }
        if cam.serial:
            data[f"cam_{i}"]["serial"] = cam.serial
    data["metadata"] = {"adjusted": False, "error": 0.0, **(metadata or {})}
    return tomli_w.dumps(data)


def rig_to_json_dict(rig: Rig) -> dict[str, Any]:
    return {
        "format": JSON_FORMAT,
        "version": JSON_VERSION,
        "units": {"translation": "mm", "image": "px"},
        "cameras": [
            {
                "name": c.name,
                "serial": c.serial,
                "size_px": list(c.size_px),
                "matrix_px": c.matrix_px.tolist(),
                "dist": c.dist.tolist(),
                "rvec": c.rvec.tolist(),
                "tvec_mm": c.tvec_mm.tolist(),
            }
            for c in rig
        ],
    }


def rig_from_json_dict(data: dict[str, Any], *, source: str = "<json>") -> Rig:
    if data.get("format") != JSON_FORMAT:
        raise ValueError(f"{source}: field 'format' must be {JSON_FORMAT!r}, got {data.get('format')!r}")
    if data.get("version") != JSON_VERSION:
        raise ValueError(f"{source}: unsupported 'version' {data.get('version')!r} (expected {JSON_VERSION})")
    cams_data = _field(data, "cameras", where=source)
    if not isinstance(cams_data, list) or not cams_data:
        raise ValueError(f"{source}: field 'cameras' must be a non-empty list")
    cams = []
    for i, c in enumerate(cams_data):
        where = f"{source} cameras[{i}]"
        rot_key = "rvec" if "rvec" in c else "rotation_matrix"
        size = _array(_field(c, "size_px", where=where), (2,), where=where, key="size_px")
        try:
            cams.append(
                Camera(
                    name=str(_field(c, "name", where=where)),
                    size_px=(int(size[0]), int(size[1])),
                    matrix_px=_array(_field(c, "matrix_px", where=where), (3, 3), where=where, key="matrix_px"),
                    dist=_array(_field(c, "dist", where=where), None, where=where, key="dist"),
                    rvec=_rotation_to_rvec(_field(c, rot_key, where=where), where=where, key=rot_key),
                    tvec_mm=_array(_field(c, "tvec_mm", where=where), (3,), where=where, key="tvec_mm"),
                    serial=str(c.get("serial", "")),
                )
            )
        except ValueError as exc:
            raise ValueError(f"{where}: {exc}") from None
    return Rig(tuple(cams))



def _rig_from_json_text(text: str, *, source: str) -> Rig:
    try:
        data = json.loads(text)
    except json.JSONDecodeError as exc:
        raise ValueError(f"{source}: not valid JSON ({exc})") from None
    return rig_from_json_dict(data, source=source)


_TEXT_PARSERS = {".json": _rig_from_json_text, ".toml": rig_from_toml_text}


def rig_from_text(text: str, *, suffix: str, source: str = "calibration") -> Rig:
    """The calibration in ``text``, the format following the file name's ``suffix`` (.toml: aniposelib,
    metres; .json: gaitcap, mm); errors name ``source``. Files are read by
    :func:`gaitcap.acquisition.readers.load_rig`."""
    parse = _TEXT_PARSERS.get(suffix.lower())
    if parse is None:
        raise ValueError(f"{source}: unknown calibration format {suffix!r} (expected .toml or .json)")
    return parse(text, source=source)


_TEXT_FORMATS = {".json": lambda rig, metadata: json.dumps(rig_to_json_dict(rig), indent=2),
                 ".toml": lambda rig, metadata: rig_to_toml_text(rig, metadata=metadata)}


def rig_to_text(rig: Rig, *, suffix: str, metadata: dict[str, Any] | None = None, where: str = "calibration") -> str:
    """The calibration file's text for a file name ending in ``suffix`` (.toml or .json; ``metadata``: TOML
    only). Written by :func:`gaitcap.acquisition.writers.save_rig`."""
    to_text = _TEXT_FORMATS.get(suffix.lower())
    if to_text is None:
        raise ValueError(f"{where}: unknown calibration format {suffix!r} (expected .toml or .json)")
    return to_text(rig, metadata)
