"""A validation result (``compare.validate``'s JSON) as the rows the page and the trial's report show.

One text per figure, rounded once here with the clinic's rounding rule (services/reports/shown.py), so the
page's validation section (``GET /trials/{id}/validation``, ``shown``) and the trial report's section
read the same. Units: event errors in ms and frames, parameter differences in the parameter's own unit
(its name says it: ``_mm``, ``_s``, ``_pct``, ...), angles in degrees.
"""

from __future__ import annotations

import json
from dataclasses import asdict, dataclass
from pathlib import Path

from gaitcap.services.reports.shown import shown, shown_signed
from gaitcap.services.validation.names import FILES, TRIAL_FOLDER

KIND_NAMES = {"heel_strike": "heel strike", "toe_off": "toe off"}


@dataclass(frozen=True)
class ShownRow:
    """One line of the agreement table: what was compared, over how many, the difference (gaitcap minus
    the reference) and how well the two agree."""

    what: str
    n: int
    difference: str
    agreement: str


def _t(x, decimals: int) -> str:
    return shown(x, decimals) or "-"


def _s(x, decimals: int) -> str:
    return shown_signed(x, decimals) or "-"


def _event(e: dict) -> ShownRow:
    return ShownRow(f"{e['side']} {KIND_NAMES.get(e['kind'], e['kind'])}", int(e["n"]),
                    f"{_s(e.get('signed_median_ms'), 0)} ms ({_s(e.get('signed_median_frames'), 2)} frames) "
                    f"median; |error| median {_t(e.get('abs_median_ms'), 0)} ms",
                    f"missed {e.get('missed', 0)}, extra {e.get('extra', 0)}")


def _parameter(name: str, s: dict) -> ShownRow:
    return ShownRow(name, int(s["n"]),
                    f"bias {_s(s.get('bias'), 2)} (95 % limits of agreement {_s(s.get('loa_low'), 2)} to "
                    f"{_s(s.get('loa_high'), 2)})", f"ICC {_t(s.get('icc'), 2)}")


def _angle(x: dict) -> ShownRow:
    return ShownRow(f"{x['side']} {x['variable'].replace('_', ' ')}", int(x["n"]),
                    f"RMSE {_t(x.get('rmse_deg'), 1)} deg, offset {_s(x.get('offset_deg'), 1)} deg, "
                    f"after offset {_t(x.get('rmse_after_offset_deg'), 1)} deg", f"r {_t(x.get('r'), 3)}")


def shown_rows(result: dict) -> list[ShownRow]:
    """The rows of ``result``: events (per side and kind), parameters (both sides pooled), angles."""
    return ([_event(e) for e in result.get("events") or []]
            + [_parameter(name, sides["all"]) for name, sides in (result.get("parameters") or {}).items()
               if "all" in sides]
            + [_angle(x) for x in result.get("angles") or []])


def alignment_text(result: dict) -> str:
    """"Against C3D FunctionalWalk.c3d: lag +0.247 s, residual 15.4 mm." (the reference's file name only)."""
    a = result.get("alignment") or {}
    name = str(result.get("reference") or "").replace("\\", "/").split("/")[-1]
    residual = shown(a.get("residual_mm"), 1)
    return (f"Against {result.get('reference_kind') or 'reference'} {name}: lag {_s(a.get('lag_s'), 3)} s"
            + (f", residual {residual} mm." if residual else ".")
            + (f" Timing: {a['timing_note']}." if a.get("timing_note") else ""))


def shown_validation(result: dict) -> dict:
    """``{"alignment": text, "rows": [row dicts], "not_compared": [texts]}`` for the page and the report."""
    return {"alignment": alignment_text(result), "rows": [asdict(r) for r in shown_rows(result)],
            "not_compared": [f"Not compared: {t}" for t in result.get("not_compared") or []]}


def stored_validation(trial_root: Path) -> dict | None:
    """The trial's ``gaitcap validate`` result (``<trial_root>/validation/validation.json``), None without one."""
    path = Path(trial_root) / TRIAL_FOLDER / FILES["json"]
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None
