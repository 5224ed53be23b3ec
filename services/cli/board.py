"""``gaitcap board --out board.pdf``: a calibration board to print at true scale, with its parameters
written on it and a board file (``board.toml``) beside it; and the board options shared with
``gaitcap calibrate`` (a board file, or flags)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import typer
from gaitcap.services.cli._common import user_errors

PX_PER_MM = 10.0  # 254 dpi
SCALE_BAR_MM = 100.0

BOARD_FILE = typer.Option(None, "--board-file", help="Board file (.toml/.json: gaitcap's board table, caliscope's "
                          "charuco.toml, anipose's config.toml or Pose2Sim's Config.toml).")
KIND = typer.Option(None, "--board", help="Board kind: checkerboard | charuco (default checkerboard).")
SQUARES = typer.Option(None, "--squares", help="Squares COLSxROWS (default 7x5 checkerboard, 5x7 charuco).")
SQUARE_MM = typer.Option(None, "--square-mm", help="Square side in mm (default 110 checkerboard, 109 charuco).")
MARKER_MM = typer.Option(None, "--marker-mm", help="ChArUco marker side in mm (default 0.75 x square).")
DICTIONARY = typer.Option(None, "--dictionary", help="ChArUco ArUco dictionary (default DICT_4X4_50).")
INVERTED = typer.Option(None, "--inverted/--not-inverted", help="ChArUco printed white markers on black "
                        "(default: try both).")
LEGACY = typer.Option(None, "--legacy-layout/--current-layout", help="ChArUco in OpenCV's pre-4.6 layout "
                      "(default: try both).")


def _squares(text: str) -> tuple[int, int]:
    x, sep, y = text.lower().partition("x")
    if not sep or not x.isdigit() or not y.isdigit():
        raise ValueError(f"--squares: expected COLSxROWS such as 7x5, got {text!r}")
    return int(x), int(y)


def board_from_options(board_file: Path | None, kind: str | None, squares: str | None, square_mm: float | None,
                       marker_mm: float | None, dictionary: str | None, inverted: bool | None,
                       legacy: bool | None):
    """The board from a board file or from flags (not both: ValueError)."""
    from gaitcap.acquisition.boards.detection import BoardConfig, make_board
    from gaitcap.acquisition.boards.file import read_board_file

    flags = {"--board": kind, "--squares": squares, "--square-mm": square_mm, "--marker-mm": marker_mm,
             "--dictionary": dictionary, "--inverted": inverted, "--legacy-layout": legacy}
    given = [k for k, v in flags.items() if v is not None]
    if board_file is not None:
        if given:
            raise ValueError(f"give the board either as --board-file or as flags, not both (flags given: {given})")
        return read_board_file(board_file)
    make = {"checkerboard": BoardConfig.checkerboard, "charuco": BoardConfig.charuco}
    kind = kind or "checkerboard"
    if kind not in make:
        raise ValueError(f"--board: choose checkerboard or charuco, got {kind!r}")
    base = make[kind]()
    sx, sy = _squares(squares) if squares else (base.squares_x, base.squares_y)
    config = BoardConfig(kind, sx, sy, square_mm or base.square_mm, marker_mm,  # type: ignore[arg-type]
                         dictionary or base.dictionary, inverted, legacy)
    make_board(config)
    return config


def board_page(config) -> tuple[np.ndarray, float]:
    """The printable page (uint8 grey) and its resolution in dots per inch: the board at true scale, its
    parameters and a 100 mm scale bar below it."""
    import cv2
    from gaitcap.acquisition.boards.detection import make_board

    px_per_mm = round(config.square_mm * PX_PER_MM) / config.square_mm  # whole pixels per square
    board_img, _ = make_board(config).texture(px_per_mm)  # an inverted ChArUco comes out inverted
    w = board_img.shape[1]
    text_h = int(40 * px_per_mm)
    page = np.full((board_img.shape[0] + text_h, w), 255, np.uint8)
    page[: board_img.shape[0]] = board_img
    y = board_img.shape[0] + int(8 * px_per_mm)
    bar = int(round(SCALE_BAR_MM * px_per_mm))
    x0 = int(5 * px_per_mm)
    cv2.rectangle(page, (x0, y), (x0 + bar, y + int(3 * px_per_mm)), 0, -1)
    lines = [config.describe(), f"bar = {SCALE_BAR_MM:g} mm: print at 100 % (no fit to page), then measure"]
    font, thick = cv2.FONT_HERSHEY_SIMPLEX, max(1, int(px_per_mm / 4))
    for k, line in enumerate(lines):
        (tw, _), _ = cv2.getTextSize(line, font, 1.0, thick)
        scale = min(0.2 * px_per_mm, (w - 2 * x0) / tw)  # about 4 mm high, narrower on small boards
        cv2.putText(page, line, (x0, y + int((14 + 12 * k) * px_per_mm)), font, scale, 0, thick, cv2.LINE_AA)
    return page, px_per_mm * 25.4


def save_page(page: np.ndarray, dpi: float, out: Path) -> None:
    """Write the page as PDF (true scale from its dpi) or PNG."""
    from PIL import Image

    img = Image.fromarray(page)
    if out.suffix.lower() == ".pdf":
        img.save(out, "PDF", resolution=dpi)
    elif out.suffix.lower() == ".png":
        img.save(out, dpi=(dpi, dpi))
    else:
        raise ValueError(f"--out {out}: use a .pdf or .png file name")


def register(app: typer.Typer) -> None:
    @app.command("board")
    def board_cmd(
        out: Path = typer.Option(..., "--out", help="Board to print: .pdf (true scale) or .png."),
        board_file: Path | None = BOARD_FILE, kind: str | None = KIND, squares: str | None = SQUARES,
        square_mm: float | None = SQUARE_MM, marker_mm: float | None = MARKER_MM,
        dictionary: str | None = DICTIONARY, inverted: bool | None = INVERTED, legacy: bool | None = LEGACY,
    ) -> None:
        """Draw a calibration board at true scale, and write its board file (OUT with .toml) beside it."""
        from gaitcap.acquisition.boards.file import board_to_toml
        from gaitcap.acquisition.fileio import atomic_write_text

        with user_errors():
            config = board_from_options(board_file, kind, squares, square_mm, marker_mm, dictionary, inverted,
                                        legacy)
            page, dpi = board_page(config)
            out.parent.mkdir(parents=True, exist_ok=True)
            save_page(page, dpi, out)
            board_toml = out.with_suffix(".toml")
            atomic_write_text(board_toml, board_to_toml(config))
        height_mm, width_mm = (np.array(page.shape) / dpi * 25.4).round(1)
        typer.echo(f"wrote {out} ({width_mm:g} x {height_mm:g} mm at {dpi:.1f} dpi) and {board_toml}: "
                   f"{config.describe()}")
