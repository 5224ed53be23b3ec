"""Board coverage while recording: exact counts of views per image cell and of moments each camera pair
saw the board together, and the advice they give (regions named only when every cell of them is empty,
cameras not linked through shared views, pairs without one)."""

import numpy as np
import pytest
from gaitcap.reconstruction.calibration.coverage import (
    BoardSighting,
    board_cells,
    board_coverage,
    region_of,
)

MS = 1_000_000


def test_board_cells_of_corners_with_nan_and_outside_the_image():
    corners = np.array([[0.0, 0.0], [639.4, 479.4], [320.0, 10.0], [np.nan, np.nan], [-30.0, 250.0], [319.4, 10.0]])
    # 640 x 480 px in 4 x 4 cells of 160 x 120 px: (0,0) -> 0, (639,479) -> 15, x 320 -> column 2, x 319 -> 1,
    # x -30 (outside) -> column 0, y 250 -> row 2
    assert board_cells(corners, width_px=640, height_px=480, grid=4) == (0, 1, 2, 8, 15)
    assert board_cells(np.full((4, 2), np.nan), width_px=640, height_px=480) == ()
    with pytest.raises(ValueError, match="640 x 0 px"):
        board_cells(corners, width_px=640, height_px=0)


def test_region_words_on_a_4_by_4_and_a_6_by_6_grid():
    assert [region_of(0, c, 4) for c in range(4)] == ["upper left", "top", "top", "upper right"]
    assert [region_of(r, 3, 4) for r in range(4)] == ["upper right", "right", "right", "lower right"]
    assert region_of(1, 2, 4) == "centre" and region_of(3, 0, 4) == "lower left"
    assert [region_of(5, c, 6) for c in range(6)] == ["lower left"] * 2 + ["bottom"] * 2 + ["lower right"] * 2


def _sightings():
    # moment 1 (t 0 and 3 ms): cam01, cam02; moment 2 (t 500 ms): cam01, cam03 (twice: counted once as a moment);
    # moment 3 (t 1000 ms): cam02 alone; cam09 is not asked for and left out
    return [BoardSighting("cam01", 0, (0, 1, 5)), BoardSighting("cam02", 3 * MS, (5,)),
            BoardSighting("cam01", 500 * MS, (5, 6)), BoardSighting("cam03", 502 * MS, (15,)),
            BoardSighting("cam03", 505 * MS, (15, 14)), BoardSighting("cam02", 1000 * MS, (10,)),
            BoardSighting("cam09", 0, (0,))]


def test_counts_per_cell_and_pairs_are_exact():
    cov = board_coverage(_sightings(), cameras=["cam01", "cam02", "cam03", "cam04"], grid=4, together_ns=50 * MS)
    by = {c.name: c for c in cov.cameras}
    assert [by[n].views for n in ("cam01", "cam02", "cam03", "cam04")] == [2, 2, 2, 0]
    assert by["cam01"].cells == ((1, 1, 0, 0), (0, 2, 1, 0), (0, 0, 0, 0), (0, 0, 0, 0))
    assert by["cam02"].cells[1] == (0, 1, 0, 0) and by["cam02"].cells[2] == (0, 0, 1, 0)
    assert by["cam03"].cells[3] == (0, 0, 1, 2)
    assert cov.moments == 3
    assert dict(cov.pairs) == {("cam01", "cam02"): 1, ("cam01", "cam03"): 1, ("cam01", "cam04"): 0,
                               ("cam02", "cam03"): 0, ("cam02", "cam04"): 0, ("cam03", "cam04"): 0}
    # a window too short for the 3 ms between cam01 and cam02 splits their moment
    assert dict(board_coverage(_sightings(), cameras=["cam01", "cam02"], together_ns=2 * MS).pairs) == {
        ("cam01", "cam02"): 0}


def test_advice_names_empty_regions_unlinked_groups_and_pairs():
    cov = board_coverage(_sightings(), cameras=["cam01", "cam02", "cam03", "cam04"], grid=4, together_ns=50 * MS)
    advice = cov.advice()
    assert "cam04: no board view yet: show it the board" in advice
    # cam01 saw cells 0, 1, 5, 6 only: every cell of the bottom and the right half is empty, the top is not
    # (cell 1), nor the upper left (cell 0); the centre (cells 5, 6, 9, 10) has views
    cam01 = next(a for a in advice if a.startswith("cam01:"))
    assert cam01 == "cam01: no views in the upper right, left, right, lower left, bottom, lower right"
    assert cov.groups() == [["cam01", "cam02", "cam03"]]
    assert "cam02-cam03 share no view: hold the board where both see it" in advice
    assert "cam01-cam04 share no view: hold the board where both see it" in advice
    full = tuple(range(16))
    split = board_coverage([BoardSighting("a", 0, full), BoardSighting("b", 0, full), BoardSighting("c", 10**9, full)],
                           cameras=["a", "b", "c"], together_ns=MS)
    assert split.groups() == [["a", "b"], ["c"]]
    assert split.advice() == ("no shared view links these groups of cameras: a, b; c: hold the board where "
                              "cameras of two groups both see it",
                              "a-c share no view: hold the board where both see it",
                              "b-c share no view: hold the board where both see it")


def test_a_camera_with_some_empty_cells_but_no_empty_region_and_many_pairs_summed():
    corners_only = (0, 3, 12, 15, 1, 4, 7, 13, 5)  # cells of each region but 2, 8, 11, 14, 6, 9, 10
    names = [f"cam{i:02d}" for i in range(1, 9)]
    cov = board_coverage([BoardSighting(n, i * 10**9, corners_only) for i, n in enumerate(names)],
                         cameras=names, together_ns=MS)
    assert cov.cameras[0].empty_regions() == []
    advice = cov.advice()
    assert advice[0] == "cam01: 7 of 16 image cells without a view"
    assert advice[-1] == "28 of 28 camera pairs share no view (see the pair table)"
    out = cov.to_dict()
    assert out["grid"] == 4 and out["moments"] == 8 and out["cameras"][0]["views"] == 1
    assert out["pairs"][0] == {"cameras": ["cam01", "cam02"], "together": 0}


def test_bad_input_is_named():
    with pytest.raises(ValueError, match="camera cam01: cells \\[16\\] outside a 4 x 4 grid"):
        board_coverage([BoardSighting("cam01", 0, (16,))], cameras=["cam01"], together_ns=MS)
    with pytest.raises(ValueError, match="together_ns"):
        board_coverage([], cameras=["cam01"], together_ns=-1)
