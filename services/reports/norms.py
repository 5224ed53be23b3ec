"""Normative spatiotemporal values by parameter, sex and age range, read from a CSV a clinic can replace.

The shipped table (``norms.csv``, package data) holds, for healthy adults by sex and age group:
comfortable gait speed aged 20-69 by decade from Bohannon RW, Age and Ageing 1997;26(1):15-19 (unverified
against the article's table: only the men 40-49 mean is confirmed, by the abstract; each row's source
says so), and every spatiotemporal parameter of the report (gait speed, cadence, step and stride length,
step width, step and stride time, stance, swing, single and double support) aged 70-89 from Hollman JH,
McDade EM, Petersen RC, Gait & Posture 2011;34(1):111-118. Under 70 no other parameter has a row ("no
reference"). Each row names its source; the file's comments carry the full citations (printed in the
report) and how the values were taken from the publications.
Columns: ``parameter, sex, age_min, age_max, mean, sd, unit, source`` and, optional, ``sd_checked``
(``yes``/``no``, default yes): a row whose SD could not be checked against its source (``no``: the
shipped Bohannon 1997 rows) gives no normal range, no z-score and no finding (:meth:`NormTable.find`
skips it). Lines starting with ``#`` are comments. A bad row is refused with its line and column named.
"""

from __future__ import annotations

import csv
import functools
import io
import math
from collections.abc import Mapping
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

COLUMNS = ("parameter", "sex", "age_min", "age_max", "mean", "sd", "unit", "source")
NO_PATIENT_REFERENCE = "no reference for this patient"
# unit -> the physical limits of a value in it (a normal range is clipped to them: no negative width)
PHYSICAL_LIMITS = {"% cycle": (0.0, 100.0)}
DEFAULT_LIMITS = (0.0, math.inf)  # speeds, lengths, widths, times, cadence: never below 0
SEXES = ("female", "male")
CONVERT = {"age_min": int, "age_max": int, "mean": float, "sd": float}
CHECKED = {"yes": True, "no": False}  # the optional column sd_checked


@dataclass(frozen=True)
class NormRow:
    """Mean and SD of ``parameter`` (its unit) for ``sex`` aged ``age_min``-``age_max`` years (inclusive)."""

    parameter: str
    sex: str
    age_min: int
    age_max: int
    mean: float
    sd: float
    unit: str
    source: str
    sd_checked: bool = True

    def z(self, value: float) -> float:
        """The z-score of ``value`` against this row."""
        return (value - self.mean) / self.sd

    def band(self, k: float = 1.96) -> tuple[float, float]:
        """mean -+ k SD (k = 1.96: the central 95 %), clipped to the unit's physical limits
        (:data:`PHYSICAL_LIMITS`: a step width's range starts at 0 mm, never below)."""
        lo, hi = PHYSICAL_LIMITS.get(self.unit, DEFAULT_LIMITS)
        return max(lo, self.mean - k * self.sd), min(hi, self.mean + k * self.sd)


def percentile(z: float) -> float:
    """The normal distribution's percentile (0-100) of a z-score."""
    return 50.0 * (1.0 + math.erf(z / math.sqrt(2.0)))


@dataclass(frozen=True)
class NormTable:
    """The rows of one normative CSV and its comment lines (the citations)."""

    rows: tuple[NormRow, ...]
    citations: tuple[str, ...]
    origin: str

    def find(self, parameter: str, *, sex: str, age: int | None) -> NormRow | None:
        """The normal range (a row with a checked SD) for ``parameter`` of this sex and age; None when the
        table has none, only one whose SD is not checked (mean only: no range, no z-score), or sex/age
        are unknown."""
        row = self.row_for(parameter, sex=sex, age=age)
        return row if row is not None and row.sd_checked else None

    def row_for(self, parameter: str, *, sex: str, age: int | None) -> NormRow | None:
        """The table's row for ``parameter`` of this sex and age, checked SD or not (None: none)."""
        if not sex or age is None:
            return None
        for row in self.rows:
            if row.parameter == parameter and row.sex == sex and row.age_min <= age <= row.age_max:
                return row
        return None


def missing_for_patient(*, sex: str, age: int | None) -> str:
    """What of the patient a norm needs is not recorded ("sex and birth year not recorded"), "" if both are."""
    gaps = [what for what, known in (("sex", bool(sex)), ("birth year", age is not None)) if not known]
    return f"{' and '.join(gaps)} not recorded" if gaps else ""


class NormsError(ValueError):
    """A normative CSV that cannot be used; the message names the file, line and column."""


def _cell(cells: dict, column: str, where: str, convert=str):
    raw = (cells.get(column) or "").strip()
    try:
        value = convert(raw)
    except ValueError:
        raise NormsError(f"{where}, column {column}: {raw!r} is not a number") from None
    if value == "":
        raise NormsError(f"{where}, column {column}: empty")
    return value


def _checked(cells: dict, where: str) -> bool:
    raw = (cells.get("sd_checked") or "yes").strip().lower()
    if raw not in CHECKED:
        raise NormsError(f"{where}, column sd_checked: {raw!r}: use yes or no")
    return CHECKED[raw]


def _row(cells: dict, where: str, units: Mapping[str, str] | None) -> NormRow:
    values = {c: _cell(cells, c, where, CONVERT.get(c, str)) for c in COLUMNS}
    row = NormRow(**{**values, "sex": values["sex"].lower()}, sd_checked=_checked(cells, where))
    checks = (
        ("parameter", units is not None and row.parameter not in units,
         f"unknown parameter {row.parameter!r} (known: {', '.join(units or ())})"),
        ("sex", row.sex not in SEXES, f"{row.sex!r}: use female or male"),
        ("unit", units is not None and row.parameter in units and row.unit != units.get(row.parameter),
         f"{row.parameter} is in {(units or {}).get(row.parameter)}, not {row.unit!r}"),
        ("sd", not (math.isfinite(row.sd) and row.sd > 0), f"{row.parameter} needs sd > 0"),
        ("mean", not math.isfinite(row.mean), f"{row.parameter} needs a finite mean"),
        ("age_max", row.age_min > row.age_max, f"age_min {row.age_min} > age_max {row.age_max}"),
    )
    for column, bad, text in checks:
        if bad:
            raise NormsError(f"{where}, column {column}: {text}")
    return row


def _check_overlaps(rows: list[tuple[int, NormRow]], origin: str) -> None:
    seen: dict[tuple[str, str], list[tuple[int, NormRow]]] = {}
    for line, row in rows:
        for other_line, other in seen.setdefault((row.parameter, row.sex), []):
            if row.age_min <= other.age_max and other.age_min <= row.age_max:
                raise NormsError(f"{origin} line {line}, column age_min: {row.parameter} {row.sex} aged "
                                 f"{row.age_min}-{row.age_max} overlaps line {other_line} "
                                 f"({other.age_min}-{other.age_max})")
        seen[(row.parameter, row.sex)].append((line, row))


def parse_norms(text: str, origin: str = "norms", *, units: Mapping[str, str] | None = None) -> NormTable:
    """Parse a normative CSV. ``units``: parameter -> unit, when given only those parameters in those
    units are accepted. NormsError (a ValueError) naming the file, line and column of a bad row."""
    lines = text.splitlines()
    comments = [ln.lstrip("# ").rstrip() for ln in lines if ln.startswith("#")]
    first = next((i for i, ln in enumerate(comments) if ln.startswith("Source")), 0)
    citations = tuple(comments[first:])  # from the first "Source" line: what the report prints
    body = [(i + 1, ln) for i, ln in enumerate(lines) if ln.strip() and not ln.startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(ln for _, ln in body)))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
    if missing:
        raise NormsError(f"{origin}: missing column(s) {', '.join(missing)}")
    rows = [(body[k + 1][0], _row(cells, f"{origin} line {body[k + 1][0]}", units)) for k, cells in enumerate(reader)]
    _check_overlaps(rows, origin)
    return NormTable(tuple(r for _, r in rows), citations, origin)


def load_norms(path: str | Path | None = None, *, units: Mapping[str, str] | None = None) -> NormTable:
    """The clinic's CSV at ``path``, else the shipped table. The parsed table is kept per file, its
    modification time (ns) and size: a changed file is read and checked again, a bad one is refused
    each time (NormsError) and never kept."""
    units_key = None if units is None else tuple(sorted(units.items()))
    if path:
        stat = Path(path).stat()
        return _parsed(Path(path), str(path), stat.st_mtime_ns, stat.st_size, units_key)
    shipped = resources.files("gaitcap.services.reports").joinpath("norms.csv")
    if not isinstance(shipped, Path):  # inside a zip: it does not change
        return _parsed(shipped, "shipped norms.csv", None, None, units_key)
    stat = shipped.stat()
    return _parsed(shipped, "shipped norms.csv", stat.st_mtime_ns, stat.st_size, units_key)


@functools.lru_cache(maxsize=8)
def _parsed(source, origin: str, mtime_ns: int | None, size: int | None,
            units_key: tuple[tuple[str, str], ...] | None) -> NormTable:
    """``source``'s table (a Path or the package's file); the other arguments only tell versions apart."""
    units = None if units_key is None else dict(units_key)
    return parse_norms(source.read_text(encoding="utf-8"), origin, units=units)
