"""A validation study: many (trial, reference) pairs compared on the research executors, then the table
a validation paper reports (each parameter: n, bias, 95 % limits of agreement, ICC(A,1), MAE over every
paired step of every pair; cadence and speed over the pairs, one value each) and the pairs that dominate
the disagreement.

A pair dominates a parameter's disagreement when it holds at least ``DOMINANT_SHARE`` of the sum of
squared differences from the bias while holding less than that share of its values (a few pairs carrying
most of the spread; that pair's own validation.json tells why).

Pairs: a CSV with columns ``trial``, ``reference`` (paths relative to the CSV's folder allowed; an
optional ``name``), or a folder where each trial folder ``<name>/`` sits beside its reference
``<name>.c3d`` / ``.trc`` / ``.csv``.
"""

from __future__ import annotations

import csv
import json
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.services.research.executors import Inline, LocalPool, RayCluster
from gaitcap.services.validation.compare import ICC_FORM
from gaitcap.services.validation.statistics import agreement

DOMINANT_SHARE = 0.5
REFERENCE_SUFFIXES = (".c3d", ".trc", ".csv")
EXECUTORS = {"inline": lambda workers: Inline(), "local": lambda workers: LocalPool(workers=workers or 2),
             "ray": lambda workers: RayCluster()}


@dataclass(frozen=True)
class Pair:
    name: str
    trial: str
    reference: str
    out: str = ""


def find_pairs(source: str | Path) -> list[Pair]:
    """The pairs of a CSV or a folder (ValueError naming the file, line or folder that is wrong)."""
    source = Path(source)
    if source.is_file():
        with open(source, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            missing = [c for c in ("trial", "reference") if c not in (reader.fieldnames or ())]
            if missing:
                raise ValueError(f"{source}: pairs CSV lacks column(s) {', '.join(missing)}")
            rows = list(reader)
        pairs = []
        for k, row in enumerate(rows, start=2):
            trial, ref = (source.parent / row["trial"]), (source.parent / row["reference"])
            pairs.append(Pair(row.get("name") or Path(row["trial"]).name or f"pair{k}", str(trial), str(ref)))
    elif source.is_dir():
        pairs = [Pair(d.name, str(d), str(r)) for d in sorted(p for p in source.iterdir() if p.is_dir())
                 for r in [next((d.with_suffix(s) for s in REFERENCE_SUFFIXES if d.with_suffix(s).is_file()), None)]
                 if r is not None]
    else:
        raise ValueError(f"pairs {source}: no such file or folder")
    if not pairs:
        raise ValueError(f"pairs {source}: no pairs (a folder needs <name>/ beside <name>.c3d|.trc|.csv)")
    names = [p.name for p in pairs]
    dup = next((n for n in names if names.count(n) > 1), None)
    if dup:
        raise ValueError(f"pairs {source}: two pairs are named {dup!r}")
    return pairs


def compare_pair(pair: Pair) -> dict:
    """One pair in a worker: its result, or its error (never raises for the pair's own problems)."""
    from gaitcap.services.validation.files import write_validation

    try:
        return {"name": pair.name, "result": write_validation(pair.trial, pair.reference, pair.out)}
    except (ValueError, FileNotFoundError, KeyError) as exc:
        return {"name": pair.name, "error": str(exc)}


def _values(results: dict[str, dict], name: str) -> dict[str, list[tuple[float, float]]]:
    out = {}
    for pair, r in results.items():
        if name in r["trial_parameters"]:
            v = r["trial_parameters"][name]
            out[pair] = [(v["trial"], v["reference"])]
        else:
            out[pair] = [tuple(p["values"][name]) for p in r["step_pairs"]]
    return out


def _dominant(by_pair: dict[str, list[tuple[float, float]]], bias: float) -> list[str]:
    sq = {k: [(a - b - bias) ** 2 for a, b in v if a is not None and b is not None and np.isfinite(a - b)]
          for k, v in by_pair.items()}
    total, count = sum(sum(v) for v in sq.values()), sum(len(v) for v in sq.values())
    if total <= 0 or len([k for k, v in sq.items() if v]) < 3:
        return []
    return sorted(k for k, v in sq.items() if sum(v) >= DOMINANT_SHARE * total and len(v) < DOMINANT_SHARE * count)


def study_table(results: dict[str, dict]) -> list[dict]:
    """One row per parameter over all pairs (``results``: pair name -> validation result)."""
    from gaitcap.reconstruction.validation.steps import PARAMETERS, TRIAL_PARAMETERS

    rows = []
    for name in (*PARAMETERS, *TRIAL_PARAMETERS):
        by_pair = _values(results, name)
        stats = agreement([v for vals in by_pair.values() for v in vals])
        rows.append({"parameter": name, **stats, "pairs": len([v for v in by_pair.values() if v]),
                     "dominant_pairs": _dominant(by_pair, stats["bias"]) if stats["n"] else []})
    return rows


def run_study(pairs: list[Pair], out: str | Path, *, executor: str = "local", workers: int | None = None,
              on_pair: Callable[[], None] | None = None) -> dict:
    """Compare every pair (each into ``out/<name>/``) on the chosen executor; write ``study.json`` and
    ``study.csv``; the study as a dict."""
    if executor not in EXECUTORS:
        raise ValueError(f"--executor: expected one of {', '.join(EXECUTORS)}, got {executor!r}")
    out = Path(out)
    items = [Pair(p.name, p.trial, p.reference, str(out / p.name)) for p in pairs]
    done = {}
    with EXECUTORS[executor](workers).open() as ex:
        for r in ex.map_unordered(compare_pair, items):
            done[r["name"]] = r
            if on_pair:
                on_pair()
    results = {k: v["result"] for k, v in sorted(done.items()) if "result" in v}
    failed = [{"name": k, "error": v["error"]} for k, v in sorted(done.items()) if "error" in v]
    events = {}
    for kind in ("heel_strike", "toe_off"):
        errs = [(t - r) * res["fps"] for res in results.values() for e in res["events"] if e["kind"] == kind
                for t, r in zip(e["trial_s"], e["reference_s"], strict=True)]
        events[kind] = {"n": len(errs), "signed_median_frames": float(np.median(errs)) if errs else float("nan"),
                        "abs_median_frames": float(np.median(np.abs(errs))) if errs else float("nan")}
    study = {"icc_form": ICC_FORM, "pairs_ok": len(results), "failed": failed, "table": study_table(results),
             "events": events}
    from gaitcap.reconstruction.jsonable import json_ready

    study = json_ready(study)
    out.mkdir(parents=True, exist_ok=True)
    atomic_write_text(out / "study.json", json.dumps(study, indent=2) + "\n")
    cols = ("parameter", "n", "pairs", "bias", "sd", "loa_low", "loa_high", "icc", "mae", "dominant_pairs")
    lines = [",".join(cols)] + [",".join(" ".join(r[c]) if c == "dominant_pairs" else str(r[c]) for c in cols)
                                for r in study["table"]]
    atomic_write_text(out / "study.csv", "\n".join(lines) + "\n")
    return study
