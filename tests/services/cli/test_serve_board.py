"""``gaitcap serve --board-file``: the clinic's board file (any format the board reader knows) becomes the
board recorded on board recordings, as a board file's ``[board]`` fields; a bad file stops serve at once."""

import gaitcap.api.server
from gaitcap.acquisition.boards.file import board_from_dict, read_board_file
from gaitcap.services.cli import app
from gaitcap.services.cli.serve import board_fields
from typer.testing import CliRunner

CALISCOPE = """columns = 4
rows = 5
board_height = 11.0
board_width = 8.5
dictionary = "DICT_4X4_1000"
units = "inch"
aruco_scale = 0.75
square_size_overide_cm = 5.4
inverted = true
"""


def test_a_caliscope_board_file_gives_the_same_board_as_board_fields(tmp_path):
    path = tmp_path / "charuco.toml"
    path.write_text(CALISCOPE)
    fields = board_fields(path)
    assert (fields["kind"], fields["squares"], fields["square_mm"]) == ("charuco", [4, 5], 54.0)
    assert fields["dictionary"] == "DICT_4X4_1000" and fields["inverted"] is True
    assert board_from_dict({"board": fields}) == read_board_file(path)  # what the worker reads back


def test_serve_refuses_a_board_file_that_is_not_there_or_not_a_board(tmp_path):
    (tmp_path / "notes.toml").write_text('title = "not a board"\n')
    for name, words in (("missing.toml", "does not exist"), ("notes.toml", "not a board file")):
        result = CliRunner().invoke(app, ["serve", "--no-bus", "--data-dir", str(tmp_path), "--board-file",
                                          str(tmp_path / name)])
        assert result.exit_code == 2 and words in result.output and name in result.output, result.output


def test_serve_prints_the_board_it_records(tmp_path, monkeypatch):
    monkeypatch.delenv("GAITCAP_BOARD_FILE", raising=False)
    served = []
    monkeypatch.setattr(gaitcap.api.server, "serve", lambda settings, link, scene=None: served.append(settings))
    path = tmp_path / "charuco.toml"
    path.write_text(CALISCOPE)
    for extra, words in (
        (["--board-file", str(path)], f"calibration board: {read_board_file(path).describe()} (board file {path})"),
        ([], "calibration board: checkerboard 7 x 5 squares of 110 mm (the default board: no --board-file)"),
    ):
        result = CliRunner().invoke(app, ["serve", "--no-bus", "--data-dir", str(tmp_path), *extra])
        assert result.exit_code == 0 and words in result.output, result.output
    assert served[0].board == board_fields(path) and served[1].board is None
