"""The board of a calibration: a board description checked when its recording starts (the API's), and
the board a calibration searches for (the worker's). Only the board file's parser: nothing here reaches
recordings, drivers or detectors, so the API can check a board without them."""

from __future__ import annotations

from gaitcap.services.catalog.calibrations import CalibrationInfo


def check_board(board: dict) -> None:
    """ValueError naming what is wrong when ``board`` (a board file's ``[board]`` fields) is not a board the
    worker can search for (an unknown dictionary, markers as large as the squares, ...): checked when the
    board recording starts, not after the board has been filmed."""
    from gaitcap.acquisition.boards.file import board_from_dict

    board_from_dict({"board": board}, source="board")


def board_used(cal: CalibrationInfo):
    """(BoardConfig, words naming it) of a calibration: its recorded board, else the default board.
    ValueError naming the field when the recorded description is not a board."""
    from gaitcap.acquisition.boards.detection import BoardConfig
    from gaitcap.acquisition.boards.file import board_from_dict

    if cal.board is None:
        board = BoardConfig()
        return board, f"{board.describe()} (the default board: none was given)"
    board = board_from_dict({"board": cal.board}, source=f"calibration {cal.id} board")
    return board, board.describe()
