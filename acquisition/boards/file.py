"""Board files: the board described once, kept with the rig, read instead of command-line flags.

Formats (recognised by their fields):

- gaitcap's own, TOML or JSON, a ``[board]`` table::

      [board]
      kind = "charuco"          # or "checkerboard"
      squares = [4, 5]          # columns x rows of squares
      square_mm = 54.0
      marker_mm = 40.5          # ChArUco only (default 0.75 x square)
      dictionary = "DICT_4X4_1000"
      inverted = true           # optional: white markers on black (default: try both)
      legacy_layout = false     # optional: OpenCV's pre-4.6 layout (default: try both)

- caliscope's ``charuco.toml`` (columns, rows, dictionary, aruco_scale, square_size_overide_cm or the
  board's width and height in its units, inverted, legacy_pattern);
- anipose's ``config.toml`` ``[calibration]`` section (board_type, board_size, board_square_side_length,
  board_marker_length, board_marker_bits, board_marker_dict_number; lengths in mm; a checkerboard's
  board_size counts inner corners);
- Pose2Sim's ``Config.toml`` ``[calibration.calculate]`` section (a checkerboard: extrinsics board
  ``extrinsics_corners_nb`` [H, W] inner corners and ``extrinsics_square_size`` in mm, or the
  intrinsics board when no extrinsics board is given).
"""

from __future__ import annotations

import json
import os
import tomllib
from collections.abc import Callable
from pathlib import Path
from typing import Any

from gaitcap.acquisition.boards.detection import BoardConfig, make_board

CM_PER_UNIT = {"cm": 1.0, "inch": 2.54, "mm": 0.1, "m": 100.0}


def _need(table: dict[str, Any], key: str, where: str) -> Any:
    if key not in table:
        raise ValueError(f"{where}: field {key!r} is missing")
    return table[key]


def _pair(value: Any, key: str, where: str) -> tuple[int, int]:
    if not isinstance(value, list | tuple) or len(value) != 2 or not all(isinstance(v, int) for v in value):
        raise ValueError(f"{where}: field {key!r} must be two whole numbers, got {value!r}")
    return int(value[0]), int(value[1])


def _gaitcap(data: dict[str, Any], where: str) -> BoardConfig:
    board = data["board"]
    where = f"{where} [board]"
    kind = _need(board, "kind", where)
    sx, sy = _pair(_need(board, "squares", where), "squares", where)
    return BoardConfig(kind, sx, sy, float(_need(board, "square_mm", where)), board.get("marker_mm"),
                       board.get("dictionary", "DICT_4X4_50"), board.get("inverted"), board.get("legacy_layout"))


def _caliscope(data: dict[str, Any], where: str) -> BoardConfig:
    cols, rows = int(data["columns"]), int(data["rows"])
    square_cm = data.get("square_size_overide_cm")
    if square_cm is None:
        unit = data.get("units", "inch")
        if unit not in CM_PER_UNIT:
            raise ValueError(f"{where}: units {unit!r} unknown (one of {sorted(CM_PER_UNIT)})")
        square_cm = min(float(_need(data, "board_width", where)) / cols,
                        float(_need(data, "board_height", where)) / rows) * CM_PER_UNIT[unit]
    square_mm = 10.0 * float(square_cm)
    return BoardConfig("charuco", cols, rows, square_mm, square_mm * float(data.get("aruco_scale", 0.75)),
                       str(_need(data, "dictionary", where)), bool(data.get("inverted", False)),
                       bool(data.get("legacy_pattern", False)))


def _anipose(data: dict[str, Any], where: str) -> BoardConfig:
    calib = data["calibration"]
    where = f"{where} [calibration]"
    kind = str(_need(calib, "board_type", where)).lower()
    sx, sy = _pair(_need(calib, "board_size", where), "board_size", where)
    square = float(_need(calib, "board_square_side_length", where))
    if kind == "checkerboard":
        return BoardConfig.checkerboard(sx + 1, sy + 1, square)  # anipose counts inner corners
    if kind != "charuco":
        raise ValueError(f"{where}: board_type {kind!r} is not supported (checkerboard or charuco)")
    bits, count = int(calib.get("board_marker_bits", 4)), int(calib.get("board_marker_dict_number", 50))
    return BoardConfig("charuco", sx, sy, square, float(_need(calib, "board_marker_length", where)),
                       f"DICT_{bits}X{bits}_{count}")


def _pose2sim(data: dict[str, Any], where: str) -> BoardConfig:
    calc = data["calibration"]["calculate"]
    board = calc.get("extrinsics", {}).get("board", {})
    if "extrinsics_corners_nb" in board:
        corners, square, key = board["extrinsics_corners_nb"], board.get("extrinsics_square_size"), "extrinsics"
    else:
        intr = calc.get("intrinsics", {})
        corners, square, key = intr.get("intrinsics_corners_nb"), intr.get("intrinsics_square_size"), "intrinsics"
    h, w = _pair(corners, f"{key}_corners_nb", f"{where} [calibration.calculate]")
    if not isinstance(square, int | float):
        raise ValueError(f"{where} [calibration.calculate]: {key}_square_size (mm) must be one number, got {square!r}")
    return BoardConfig.checkerboard(w + 1, h + 1, float(square))


FORMATS: dict[str, tuple[Callable[[dict[str, Any]], bool], Callable[[dict[str, Any], str], BoardConfig]]] = {
    "gaitcap": (lambda d: isinstance(d.get("board"), dict), _gaitcap),
    "caliscope": (lambda d: {"columns", "rows", "dictionary"} <= d.keys(), _caliscope),
    "anipose": (lambda d: isinstance(d.get("calibration"), dict) and "board_type" in d["calibration"], _anipose),
    "pose2sim": (lambda d: isinstance(d.get("calibration"), dict) and "calculate" in d["calibration"], _pose2sim),
}


def board_from_dict(data: dict[str, Any], *, source: str = "<board>") -> BoardConfig:
    """The board described by parsed TOML/JSON in any known format (ValueError names what is wrong)."""
    for check, read in FORMATS.values():
        if check(data):
            config = read(data, source)
            make_board(config)  # validates sizes and the dictionary, naming the problem
            return config
    raise ValueError(f"{source}: not a board file; expected a [board] table, caliscope's charuco.toml, "
                     "anipose's config.toml [calibration] or Pose2Sim's Config.toml [calibration.calculate]")


def read_board_file(path: str | os.PathLike) -> BoardConfig:
    """A board from a .toml or .json board file (see the module docstring for the formats)."""
    path = Path(path)
    if not path.is_file():
        raise ValueError(f"board file {path} does not exist")
    text = path.read_text()
    try:
        data = json.loads(text) if path.suffix.lower() == ".json" else tomllib.loads(text)
    except (json.JSONDecodeError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"board file {path}: not valid {path.suffix.lstrip('.').upper()} ({exc})") from None
    return board_from_dict(data, source=str(path))


def board_to_toml(config: BoardConfig) -> str:
    """gaitcap's own board file text for a board."""
    lines = ["[board]", f'kind = "{config.kind}"', f"squares = [{config.squares_x}, {config.squares_y}]",
             f"square_mm = {config.square_mm!r}"]
    if config.kind == "charuco":
        if config.marker_mm is not None:
            lines.append(f"marker_mm = {config.marker_mm!r}")
        lines.append(f'dictionary = "{config.dictionary}"')
        for key in ("inverted", "legacy_layout"):
            value = getattr(config, key)
            if value is not None:
                lines.append(f"{key} = {str(value).lower()}")
    return "\n".join(lines) + "\n"
