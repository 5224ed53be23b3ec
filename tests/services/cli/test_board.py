"""``gaitcap board``: a printable board at true scale that the detector finds, with its board file."""

import re

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.acquisition.boards.file import read_board_file
from gaitcap.services.cli import app
from typer.testing import CliRunner

FLAGS = ["--board", "charuco", "--squares", "4x5", "--square-mm", "54", "--marker-mm", "40.5",
         "--dictionary", "DICT_4X4_1000", "--inverted"]


def test_board_pdf_is_true_scale_and_png_is_found(tmp_path):
    result = CliRunner().invoke(app, ["board", "--out", str(tmp_path / "board.pdf"), *FLAGS])
    assert result.exit_code == 0, result.output
    board = BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000", inverted=True)
    assert read_board_file(tmp_path / "board.toml") == board
    pdf = (tmp_path / "board.pdf").read_bytes()
    box = [float(v) for v in re.search(rb"/MediaBox \[\s*0 0 ([\d.]+) ([\d.]+)\s*\]", pdf).groups()]
    width_mm = box[0] / 72 * 25.4
    assert abs(width_mm - 5 * 54.0) < 0.5  # 4 squares and half a square of margin each side, 1 pt = 1/72 in
    result = CliRunner().invoke(app, ["board", "--out", str(tmp_path / "b.png"), "--board-file",
                                      str(tmp_path / "board.toml")])
    assert result.exit_code == 0, result.output
    page = cv2.imread(str(tmp_path / "b.png"), cv2.IMREAD_GRAYSCALE)
    page = cv2.resize(page, None, fx=0.25, fy=0.25, interpolation=cv2.INTER_AREA)  # a quicker search
    found = make_board(BoardConfig("charuco", 4, 5, 54.0, 40.5, "DICT_4X4_1000")).find(page)
    assert found.n_corners == 12 and found.variant.describe() == "inverted"
    px_per_mm = page.shape[1] / width_mm
    spacing = np.linalg.norm(np.diff(found.corners.reshape(4, 3, 2), axis=1), axis=-1)
    assert abs(np.median(spacing) / px_per_mm - 54.0) < 0.1


def test_board_file_and_flags_together_are_refused(tmp_path):
    (tmp_path / "b.toml").write_text('[board]\nkind = "checkerboard"\nsquares = [7, 5]\nsquare_mm = 110\n')
    result = CliRunner().invoke(app, ["board", "--out", str(tmp_path / "x.pdf"), "--board-file",
                                      str(tmp_path / "b.toml"), "--square-mm", "50"])
    assert result.exit_code == 2 and "not both" in result.output and "--square-mm" in result.output
