"""Method sweeps: a grid of methods and hyperparameters, and its summary in the layout of the paper's
appendix table (Table A1: one row per method; GC_5/10/20, L_reproj, L_skeleton, L_smooth, heel/toe
forward and lateral errors, step length, stride length and step width errors).

Grid file (JSON, or TOML with ``[[methods]]`` tables)::

    {"methods": [
      {"method": "robust", "label": "Robust Triangulation", "grid": {"gamma": [0.3, 0.5], "sigma_mm": [50, 100, 150]}},
      {"method": "implicit", "params": {"iterations": 30},
       "grid": {"use_confidence": [false, true], "huber_cut_px": ["none", 10]}}
    ]}

Each entry expands to the cartesian product of its ``grid`` values on top of its fixed ``params``
(parameter names as in ``gaitcap.services.research.method_specs``: dotted config paths or aliases such as ``gamma``,
``sigma_mm``, ``huber_cut_px``, ``use_confidence``); ``preset`` picks a constructor such as ``paper``.

Summary over the trials of the sweep: GC_d and the losses are means over the trials computed; the gait
errors are sigma_IQR = 0.7413 IQR (mm) of the residuals of all footfalls of all trials pooled (as the
paper's Table 2), against the walkway or the synthetic ground truth; MPJPE (mm) where ground truth exists.
"""

from __future__ import annotations

import csv
import io
import itertools
import json
import math
import tomllib
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_write_bytes
from gaitcap.services.research.method_specs import NONE_WORDS, MethodSpec

#: (column, header, unit) of the paper's appendix table, then our extra columns.
COLUMNS = (
    ("keypoints", "Keypoints", ""), ("method", "Method", ""),
    ("GC_5", "GC_5", ""), ("GC_10", "GC_10", ""), ("GC_20", "GC_20", ""),
    ("L_reproj", "L_reproj", "px"), ("L_skeleton", "L_skeleton", "mm"), ("L_smooth", "L_smooth", "mm/frame"),
    ("heel_forward_mm", "Heel Forward", "mm"), ("heel_lateral_mm", "Heel Lateral", "mm"),
    ("toe_forward_mm", "Toe Forward", "mm"), ("toe_lateral_mm", "Toe Lateral", "mm"),
    ("step_length_mm", "Step Length", "mm"), ("stride_length_mm", "Stride Length", "mm"),
    ("step_width_mm", "Step Width", "mm"),
    ("MPJPE", "MPJPE", "mm"), ("trials", "Trials", ""), ("failed", "Failed", ""),
    ("footfalls", "Footfalls", ""), ("reference", "Reference", ""), ("compute_s", "Compute", "s"),
    ("params_key", "Params key", ""),
)
MEAN_METRICS = ("GC_5", "GC_10", "GC_20", "L_reproj", "L_skeleton", "L_smooth", "MPJPE")
RESIDUAL_COLUMNS = ("heel_forward_mm", "heel_lateral_mm", "toe_forward_mm", "toe_lateral_mm", "step_length_mm",
                    "stride_length_mm", "step_width_mm")
_ENTRY_FIELDS = {"method", "preset", "label", "params", "grid"}


# ---------------------------------------------------------------------------------------------- grid
def load_grid(path: str | Path) -> list[MethodSpec]:
    """Read a grid file (``.json`` or ``.toml``) and expand it into method specs (ValueError naming
    the entry and field that is wrong)."""
    path = Path(path)
    text = path.read_text()
    try:
        data = tomllib.loads(text) if path.suffix.lower() == ".toml" else json.loads(text)
    except (ValueError, tomllib.TOMLDecodeError) as exc:
        raise ValueError(f"grid {path}: not valid {path.suffix.lstrip('.') or 'JSON'} ({exc})") from None
    if not isinstance(data, dict) or not isinstance(data.get("methods"), list) or not data["methods"]:
        raise ValueError(f"grid {path}: expected a non-empty 'methods' list")
    specs = []
    for i, entry in enumerate(data["methods"]):
        try:
            specs.extend(expand_entry(entry))
        except ValueError as exc:
            raise ValueError(f"grid {path}: methods[{i}]: {exc}") from None
    return specs


def _value(v):
    return None if isinstance(v, str) and v.lower() in NONE_WORDS else v


def expand_entry(entry: dict) -> list[MethodSpec]:
    """One grid entry -> the specs of the product of its ``grid`` lists (in file order)."""
    if not isinstance(entry, dict):
        raise ValueError("an entry must be a table/object")
    unknown = sorted(set(entry) - _ENTRY_FIELDS)
    if unknown:
        raise ValueError(f"unknown field(s) {unknown} (known: {sorted(_ENTRY_FIELDS)})")
    grid = entry.get("grid") or {}
    for name, values in grid.items():
        if not isinstance(values, list) or not values:
            raise ValueError(f"grid.{name}: must be a non-empty list")
    base = {k: _value(v) for k, v in (entry.get("params") or {}).items()}
    names = list(grid)
    specs = []
    for combo in itertools.product(*(grid[n] for n in names)):
        varied = {n: _value(v) for n, v in zip(names, combo, strict=True)}
        label = entry.get("label", "")
        if label and varied:
            label = f"{label} " + " ".join(f"{k}={_fmt(v)}" for k, v in varied.items())
        specs.append(MethodSpec(str(entry.get("method", "")), {**base, **varied}, str(entry.get("preset") or ""),
                                label))
    return specs


def _fmt(v) -> str:
    return "none" if v is None else str(v).lower() if isinstance(v, bool) else str(v)


# ---------------------------------------------------------------------------------------------- summary
@dataclass(frozen=True)
class SweepTable:
    """rows: one dict per method (keys of :data:`COLUMNS`; None where not available)."""

    rows: tuple[dict, ...]

    def csv_text(self) -> str:
        buf = io.StringIO()
        writer = csv.writer(buf, lineterminator="\n")
        writer.writerow([c for c, _, _ in COLUMNS])
        for row in self.rows:
            writer.writerow(["" if row.get(c) is None else _csv_cell(row[c]) for c, _, _ in COLUMNS])
        return buf.getvalue()

    def markdown(self) -> str:
        heads = [f"{h} ({u})" if u else h for _, h, u in COLUMNS]
        lines = ["| " + " | ".join(heads) + " |", "|" + "|".join("---" if i < 2 else "---:" for i in range(len(heads))) + "|"]
        for row in self.rows:
            lines.append("| " + " | ".join(_md_cell(c, row.get(c)) for c, _, _ in COLUMNS) + " |")
        note = ("GC_d and losses: means over trials; heel/toe and step errors: sigma_IQR (0.7413 IQR) of the "
                "per-footfall residuals against the reference, all trials pooled; MPJPE against ground truth.")
        return "\n".join(lines) + "\n\n" + note + "\n"


def _csv_cell(v) -> str:
    return f"{v:.6g}" if isinstance(v, float) else str(v)


def _md_cell(column: str, v) -> str:
    if v is None:
        return "-"
    if isinstance(v, float):
        return f"{v:.3f}" if column.startswith("GC_") else f"{v:.2f}" if abs(v) < 1e5 else f"{v:.3g}"
    return str(v)


def _mean(values) -> float | None:
    x = [float(v) for v in values if v is not None and math.isfinite(float(v))]
    return float(np.mean(x)) if x else None


def _sigma_iqr(values) -> float | None:
    from gaitcap.reconstruction.gait.walkway import ResidualStats

    stats = ResidualStats.of([v for v in values if v is not None])
    return stats.sigma_iqr if stats.n else None


def summary_row(spec: MethodSpec, results: list) -> dict:
    """The table row of one method from its stored results (``gaitcap.services.catalog.method_results.MethodResult``)."""
    ok = [r for r in results if r.ok]
    row = {"keypoints": ", ".join(sorted({r.skeleton for r in ok})) or None, "method": spec.name,
           "params_key": spec.key, "trials": len(ok), "failed": len(results) - len(ok)}
    for m in MEAN_METRICS:
        row[m] = _mean(r.metrics.get(m) for r in ok)
    pooled = {c: [] for c in RESIDUAL_COLUMNS}
    refs = set()
    for r in ok:
        for c in RESIDUAL_COLUMNS:
            pooled[c].extend((r.residuals.get("parameters") or {}).get(c, []))
        if r.residuals.get("parameters"):
            refs.add(r.residuals["reference"])
    for c in RESIDUAL_COLUMNS:
        row[c] = _sigma_iqr(pooled[c])
    row["footfalls"] = len(pooled["heel_forward_mm"]) if refs else None
    row["reference"] = ", ".join(sorted(refs)) or None
    row["compute_s"] = _mean(r.elapsed_s for r in ok)
    return row


def summarize(db, trial_ids, specs) -> SweepTable:
    """The sweep table of ``specs`` over ``trial_ids`` from the results stored in the catalog."""
    from gaitcap.services.catalog.method_results import list_results

    trial_ids = list(trial_ids)
    stored = list_results(db, trial_ids=trial_ids, params_keys=[s.key for s in specs])
    rows = [summary_row(s, [r for r in stored if r.method == s.method and r.params_key == s.key]) for s in specs]
    return SweepTable(tuple(rows))


def write_tables(table: SweepTable, out: str | Path) -> list[Path]:
    """sweep.csv, sweep.md and sweep.json in ``out`` (each written whole: temp + rename)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    paths = [out / "sweep.csv", out / "sweep.md", out / "sweep.json"]
    atomic_write_bytes(paths[0], table.csv_text().encode())
    atomic_write_bytes(paths[1], table.markdown().encode())
    atomic_write_bytes(paths[2], json.dumps({"columns": [c for c, _, _ in COLUMNS], "rows": list(table.rows)},
                                            indent=1).encode())
    return paths
