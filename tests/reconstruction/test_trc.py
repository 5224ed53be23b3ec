import numpy as np
import pytest
from gaitcap.reconstruction.trc import to_trc


def test_trc_layout_and_gaps():
    # gaps are NaN: OpenSim miscounts the columns of a row that ends in empty fields
    pts = np.arange(2 * 2 * 3, dtype=float).reshape(2, 2, 3)
    pts[1, 0] = np.nan
    text = to_trc(pts, np.array([0.0, 1 / 30]), ["a", "b"], filename="x.trc")
    lines = text.splitlines()
    assert lines[0].split("\t")[-1] == "x.trc"
    assert lines[2].split("\t")[:5] == ["30.00", "30.00", "2", "2", "mm"]
    assert lines[3].startswith("Frame#\tTime\ta\t\t\tb")
    assert lines[4].split("\t")[2:5] == ["X1", "Y1", "Z1"]
    row1 = lines[6].split("\t")
    assert row1[0] == "1" and [float(v) for v in row1[2:5]] == [0.0, 2.0, -1.0]  # OpenSim frame: y up
    row2 = lines[7].split("\t")
    assert row2[2:5] == ["NaN", "NaN", "NaN"] and float(row2[5]) == 9.0
    assert float(to_trc(pts, [0, 0.1], ["a", "b"], units="m").splitlines()[6].split("\t")[3]) == 0.002


def test_trc_bad_input_named():
    with pytest.raises(ValueError, match="joint_names"):
        to_trc(np.zeros((2, 2, 3)), [0, 1], ["a"])
    with pytest.raises(ValueError, match="times_s"):
        to_trc(np.zeros((2, 2, 3)), [0], ["a", "b"])
