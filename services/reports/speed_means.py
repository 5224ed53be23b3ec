"""Comfortable gait speed of healthy adults by age decade and sex as stratum means only (Bohannon & Andrews
2011, ``adult_gait_speed_by_decade.csv``, package data; its header says where the means were read and how
they were checked). The table has no SD: the patient's speed is given as a percentage of the age-sex mean
and no z-score or normal range is made from it (none is invented).

Columns: ``age_from, age_to, sex, parameter, unit, mean`` (gait_speed in m/s); ``#`` lines are comments.
A bad row is refused naming its line and column.
"""

from __future__ import annotations

import csv
import functools
import io
import math
from dataclasses import dataclass
from importlib import resources

FILE = "adult_gait_speed_by_decade.csv"
COLUMNS = ("age_from", "age_to", "sex", "parameter", "unit", "mean")
SOURCE = ("Bohannon RW, Andrews AW. Normal walking speed: a descriptive meta-analysis. Physiotherapy "
          "2011;97:182-189 (stratum means)")


@dataclass(frozen=True)
class SpeedMean:
    """The mean comfortable gait speed (m/s) of ``sex`` aged ``age_from``-``age_to`` years."""

    sex: str
    age_from: int
    age_to: int
    mean_m_s: float


@dataclass(frozen=True)
class SpeedComparison:
    """A patient's gait speed as a percentage of the age-sex mean (no SD: no z-score)."""

    speed_m_s: float
    reference: SpeedMean
    pct_of_mean: float

    @property
    def text(self) -> str:
        r = self.reference
        who = {"female": "women", "male": "men"}[r.sex]
        return (f"Gait speed {self.speed_m_s:.2f} m/s is {self.pct_of_mean:.0f} % of the mean comfortable speed of "
                f"healthy {who} aged {r.age_from}-{r.age_to} ({r.mean_m_s:.2f} m/s; {SOURCE}). That table gives "
                "means only: no z-score or normal range is available from it.")

    def to_dict(self) -> dict:
        r = self.reference
        return {"speed_m_s": self.speed_m_s, "mean_m_s": r.mean_m_s, "pct_of_mean": round(self.pct_of_mean, 1),
                "sex": r.sex, "age_from": r.age_from, "age_to": r.age_to, "source": SOURCE, "z": None,
                "text": self.text}


def parse_speed_means(text: str, origin: str = FILE) -> tuple[SpeedMean, ...]:
    """The rows of the table (ValueError naming line and column of a bad one)."""
    lines = [(i + 1, ln) for i, ln in enumerate(text.splitlines()) if ln.strip() and not ln.startswith("#")]
    reader = csv.DictReader(io.StringIO("\n".join(ln for _, ln in lines)))
    missing = [c for c in COLUMNS if c not in (reader.fieldnames or ())]
    if missing:
        raise ValueError(f"{origin}: missing column(s) {', '.join(missing)}")
    out = []
    for (line, _), cells in zip(lines[1:], reader, strict=True):
        where = f"{origin} line {line}"
        if cells["parameter"] != "gait_speed" or cells["unit"] != "m/s":
            raise ValueError(f"{where}, column parameter: only gait_speed in m/s, got {cells['parameter']} {cells['unit']}")
        if cells["sex"] not in ("female", "male"):
            raise ValueError(f"{where}, column sex: {cells['sex']!r}, use female or male")
        try:
            row = SpeedMean(cells["sex"], int(cells["age_from"]), int(cells["age_to"]), float(cells["mean"]))
        except ValueError:
            raise ValueError(f"{where}: age_from, age_to must be whole years and mean a number") from None
        if not (math.isfinite(row.mean_m_s) and 0.2 < row.mean_m_s < 3.0 and row.age_from <= row.age_to):
            raise ValueError(f"{where}, column mean: {row.mean_m_s} m/s for ages {row.age_from}-{row.age_to}")
        out.append(row)
    return tuple(out)


@functools.lru_cache(maxsize=1)
def speed_means() -> tuple[SpeedMean, ...]:
    """The shipped table."""
    return parse_speed_means(resources.files("gaitcap.services.reports").joinpath(FILE).read_text(encoding="utf-8"))


def compare_speed(speed_m_s: float, *, sex: str, age: int | None,
                  table: tuple[SpeedMean, ...] | None = None) -> SpeedComparison | None:
    """The patient's speed against the age-sex stratum mean; None without sex, age, speed or a stratum."""
    if not sex or age is None or not math.isfinite(speed_m_s):
        return None
    for row in table if table is not None else speed_means():
        if row.sex == sex and row.age_from <= age <= row.age_to:
            return SpeedComparison(speed_m_s, row, 100.0 * speed_m_s / row.mean_m_s)
    return None
