"""The one rounding rule for every number the clinic shows: the page, the printed page and the PDF report
write a stored value with :func:`shown` (Python's correctly rounded decimal of the stored float, ties to
even, and never "-0"), so the same value reads the same everywhere. The page receives these texts from
the API (``shown`` in ``GET /trials/{id}/parameters`` and ``GET /trials/{id}/gait``) instead of rounding
again in the browser; a change between two visits is the later shown value minus the earlier shown value
(:func:`shown_change`), so it matches the numbers beside it."""

from __future__ import annotations

import math
from collections.abc import Mapping
from decimal import Decimal

#: summary names of the catalog (``GET /gait`` ``summary``) that differ from the report's parameter names
SUMMARY_NAMES = {"gait_speed_m_per_s": "gait_speed_m_s", "cadence_steps_per_min": "cadence_steps_min"}
#: decimals of the summary's own entries that are no report parameter
SUMMARY_DECIMALS = {"step_length_asymmetry_pct": 1, "steps_count": 0}


def shown(x: float | None, decimals: int) -> str | None:
    """``x`` with ``decimals`` digits ("650", "1.18"); None when not a finite number. Zero is "0.0",
    never "-0.0"."""
    if not isinstance(x, int | float) or isinstance(x, bool) or not math.isfinite(x):
        return None
    text = f"{x:.{decimals}f}"
    return text.lstrip("-") if float(text) == 0 else text


def shown_signed(x: float | None, decimals: int) -> str | None:
    """``x`` with its sign ("+1.2", "-0.4", "0.0"), as :func:`shown`."""
    text = shown(x, decimals)
    return None if text is None else text if text.startswith("-") or float(text) == 0 else "+" + text


def shown_change(earlier: str | None, later: str | None, decimals: int) -> str | None:
    """The change between two shown values (``later - earlier``, exact in decimal): "+10", "-0.02", and
    "0" for no change; None when either is missing."""
    if earlier is None or later is None:
        return None
    delta = Decimal(later) - Decimal(earlier)
    return "0" if delta == 0 else f"{delta:+.{decimals}f}"


def summary_shown(summary: Mapping[str, Mapping], decimals: Mapping[str, int]) -> dict[str, dict[str, str | None]]:
    """Each entry of a catalog summary (``{name: {mean, sd, unit}}``) as shown: ``{name: {mean, sd}}``,
    with the report parameter's ``decimals`` (SD one more), the summary's own entries as
    :data:`SUMMARY_DECIMALS`, others with 2."""
    out = {}
    for name, stats in summary.items():
        d = decimals.get(SUMMARY_NAMES.get(name, name), SUMMARY_DECIMALS.get(name, 2))
        out[name] = {"mean": shown((stats or {}).get("mean"), d), "sd": shown((stats or {}).get("sd"), d + 1)}
    return out
