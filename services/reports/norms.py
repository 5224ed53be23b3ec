"""Normative spatiotemporal values by parameter, sex and age range, read from a CSV a clinic can replace.

The shipped table (``norms.csv``, package data) holds comfortable gait speed of healthy adults by decade
and sex from Bohannon RW, "Comfortable and maximum walking speed of adults aged 20-79 years: reference
values and determinants", Age and Ageing 1997;26(1):15-19. Other parameters (cadence, step and stride
length, step width, stance and double support) are compared only when the clinic's CSV has rows for them.
Columns: ``parameter, sex, age_min, age_max, mean, sd, unit, source``; lines starting with ``#`` are
comments (the shipped file's comments carry the full citations, printed in the report).
"""

from __future__ import annotations

import csv
import io
import math
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

COLUMNS = ("parameter", "sex", "age_min", "age_max", "mean", "sd", "unit", "source")


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

    def z(self, value: float) -> float:
        """The z-score of ``value`` against this row."""
        return (value - self.mean) / self.sd

    def band(self, k: float = 1.96) -> tuple[float, float]:
        """mean -+ k SD (k = 1.96: the central 95 %)."""
        return self.mean - k * self.sd, self.mean + k * self.sd


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
        """The row for ``parameter`` of this sex and age, None when the table has none (or sex/age unknown)."""
        if not sex or age is None:
            return None
        for row in self.rows:
            if row.parameter == parameter and row.sex == sex and row.age_min <= age <= row.age_max:
                return row
        return None


def _row(cells: dict, line: int, origin: str) -> NormRow:
    try:
        row = NormRow(parameter=cells["parameter"].strip(), sex=cells["sex"].strip().lower(),
                      age_min=int(cells["age_min"]), age_max=int(cells["age_max"]), mean=float(cells["mean"]),
                      sd=float(cells["sd"]), unit=cells["unit"].strip(), source=cells["source"].strip())
    except (KeyError, TypeError, ValueError) as exc:
        raise ValueError(f"{origin} line {line}: {exc} (columns: {', '.join(COLUMNS)})") from None
    if not (row.sd > 0 and math.isfinite(row.mean)) or row.age_min > row.age_max:
        raise ValueError(f"{origin} line {line}: {row.parameter} needs sd > 0, a finite mean and age_min <= age_max")
    return row


def parse_norms(text: str, origin: str = "norms") -> NormTable:
    """Parse a normative CSV; ValueError naming the line and column of a bad row."""
    lines = text.splitlines()
    comments = [ln.lstrip("# ").rstrip() for ln in lines if ln.startswith("#")]
    first = next((i for i, ln in enumerate(comments) if ln.startswith("Source")), 0)
    citations = tuple(comments[first:])  # from the first "Source" line: what the report prints
    body = [ln for ln in lines if ln.strip() and not ln.startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(body)))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
    if missing:
        raise ValueError(f"{origin}: missing column(s) {', '.join(missing)}")
    rows = tuple(_row(cells, i + 2, origin) for i, cells in enumerate(reader))
    return NormTable(rows, citations, origin)


def load_norms(path: str | Path | None = None) -> NormTable:
    """The clinic's CSV at ``path``, else the shipped table."""
    if path:
        return parse_norms(Path(path).read_text(encoding="utf-8"), str(path))
    text = resources.files("gaitcap.services.reports").joinpath("norms.csv").read_text(encoding="utf-8")
    return parse_norms(text, "shipped norms.csv")
