"""The normative table is parsed once per version of its file: the same file gives the same table
without reading it again, a changed file is read and checked again, a bad one is refused every time."""

import os

import pytest
from gaitcap.services.reports import norms as norms_module
from gaitcap.services.reports.content import NORM_UNITS
from gaitcap.services.reports.norms import NormsError, load_norms

HEAD = "# Source: a clinic's own table\nparameter,sex,age_min,age_max,mean,sd,unit,source\n"


def _write(path, mean_m_s: str, bump_s: int) -> None:
    path.write_text(HEAD + f"gait_speed_m_s,female,60,69,{mean_m_s},0.2,m/s,clinic\n")
    os.utime(path, ns=(1_700_000_000_000_000_000 + bump_s * 10**9,) * 2)  # a distinct modification time


def test_the_table_is_kept_until_its_file_changes(tmp_path, monkeypatch):
    path = tmp_path / "norms.csv"
    _write(path, "1.20", 0)
    first = load_norms(path, units=NORM_UNITS)
    reads = []
    real_parse = norms_module.parse_norms
    monkeypatch.setattr(norms_module, "parse_norms", lambda *a, **k: reads.append(a[1]) or real_parse(*a, **k))
    assert load_norms(path, units=NORM_UNITS) is first and load_norms(str(path), units=NORM_UNITS) is first
    assert reads == []  # neither read nor checked again
    _write(path, "1.30", 1)
    assert load_norms(path, units=NORM_UNITS).find("gait_speed_m_s", sex="female", age=64).mean == 1.30
    assert reads == [str(path)]
    _write(path, "fast", 2)
    for _ in range(2):  # a bad file is never kept: refused each time, naming the line and column
        with pytest.raises(NormsError, match="line 3, column mean: 'fast' is not a number"):
            load_norms(path, units=NORM_UNITS)
    _write(path, "1.25", 3)
    assert load_norms(path, units=NORM_UNITS).find("gait_speed_m_s", sex="female", age=64).mean == 1.25
    assert load_norms(units=NORM_UNITS) is load_norms(units=NORM_UNITS)  # the shipped table too
    assert load_norms() is not load_norms(units=NORM_UNITS)  # checked against other units: its own entry
