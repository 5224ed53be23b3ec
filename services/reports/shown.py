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
from typing import Any

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


#: joint-angle key values (degrees) and their normal values and ranges are shown with one decimal
KEY_VALUE_DECIMALS = 1


def key_values_shown(key_values: Mapping[str, Mapping] | None, norms: Mapping[str, Any]) -> dict[str, dict]:
    """``kinematics.json``'s key values as shown: side -> name -> {"mean", "sd", "outside"}; ``outside``:
    -1 below, +1 above the normal range, 0 inside or without one (``norms``: name -> ``KeyNorm``, its
    ``verdict`` of the stored mean: the report's "!"), so the page marks what the PDF marks."""
    out: dict[str, dict] = {}
    for side, values in (key_values or {}).items():
        out[side] = {}
        for name, stats in (values or {}).items():
            mean = (stats or {}).get("mean")
            norm = norms.get(name)
            verdict = norm.verdict(float(mean)) if norm is not None and shown(mean, 0) is not None else 0
            out[side][name] = {"mean": shown(mean, KEY_VALUE_DECIMALS),
                               "sd": shown((stats or {}).get("sd"), KEY_VALUE_DECIMALS), "outside": verdict}
    return out


def key_norm_shown(norm: Any) -> dict[str, Any]:
    """A key value's norm (``KeyNorm``) as shown: ``normal``, ``normal_range`` ([low, high] texts, None
    without an SD) and ``lower_limit`` (a range of motion's one-sided limit, None otherwise)."""
    band = norm.band()
    d = KEY_VALUE_DECIMALS
    return {"normal": shown(norm.normal_deg, d), "normal_range": [shown(band[0], d), shown(band[1], d)] if band else None,
            "lower_limit": shown(norm.lower_deg, d)}
