"""The one rounding rule of the page, the print and the PDF (services/reports/shown.py): the stored value
correctly rounded, never "-0"; a change computed from the shown values, so it matches them."""

import math

import pytest
from gaitcap.services.reports.content import PARAMETERS
from gaitcap.services.reports.pdf import _fmt
from gaitcap.services.reports.shown import shown, shown_change, shown_signed, summary_shown


@pytest.mark.parametrize("x,d,text", [(650.4999, 0, "650"), (650.5, 0, "650"), (651.5, 0, "652"),  # ties to even
                                      (1.175, 2, "1.18"), (0.125, 2, "0.12"), (-0.04, 1, "0.0"), (-0.0, 2, "0.00"),
                                      (-3.26, 1, "-3.3"), (12, 1, "12.0")])
def test_the_stored_value_as_shown(x, d, text):
    assert shown(x, d) == text
    assert _fmt(x, d) == text  # the PDF writes it the same way


@pytest.mark.parametrize("x", [None, math.nan, math.inf, "1.0", True])
def test_nothing_is_shown_for_what_is_not_a_number(x):
    assert shown(x, 1) is None and shown_signed(x, 1) is None
    assert _fmt(math.nan, 1) == "-"


def test_signed_values_and_changes_of_the_shown_values():
    assert [shown_signed(z, 1) for z in (0.44, -0.04, -1.96, 2.0)] == ["+0.4", "0.0", "-2.0", "+2.0"]
    # 0.994 and 1.004 show as 0.99 and 1.00: the change shown is +0.01 (the raw difference rounds to 0.01 too),
    # 649.6 and 650.4 show as 650 and 650: the change is "0", never "+1" from the raw +0.8
    assert shown_change(shown(0.994, 2), shown(1.004, 2), 2) == "+0.01"
    assert shown_change(shown(649.6, 0), shown(650.4, 0), 0) == "0"
    assert shown_change("1.18", "1.10", 2) == "-0.08" and shown_change("650", "640", 0) == "-10"
    assert shown_change(None, "1.0", 1) is None


def test_the_summary_tiles_use_the_parameters_decimals():
    decimals = {name: p.decimals for name, p in PARAMETERS.items()}
    got = summary_shown({"gait_speed_m_per_s": {"mean": 1.1849, "unit": "m/s"},
                         "cadence_steps_per_min": {"mean": 110.04, "unit": "steps/min"},
                         "step_length_mm": {"mean": 649.7, "sd": 12.34, "unit": "mm"},
                         "steps_count": {"mean": 11.0, "unit": ""}}, decimals)
    assert got == {"gait_speed_m_per_s": {"mean": "1.18", "sd": None}, "cadence_steps_per_min": {"mean": "110.0", "sd": None},
                   "step_length_mm": {"mean": "650", "sd": "12.3"}, "steps_count": {"mean": "11", "sd": None}}
