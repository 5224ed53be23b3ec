"""``gaitcap validate``'s files: everything is computed and drawn first, then written, each file by
rename (acquisition.fileio), so a pair that fails leaves no file and a finished one leaves all of them.

Files in the output folder (``FILES``): ``validation.json`` (the whole result), ``validation.csv`` (one row
per event side and kind, parameter and side, angle), ``bland_altman.png``, ``angles.png`` (when angles
were compared) and ``validation.pdf`` (the report).
"""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import numpy as np
from gaitcap.acquisition.fileio import atomic_write_bytes
from gaitcap.acquisition.references import read_reference
from gaitcap.reconstruction.jsonable import json_ready
from gaitcap.reconstruction.validation.align import interp_nan
from gaitcap.services.validation.compare import ValidateConfig, validate
from gaitcap.services.validation.names import FILES
from gaitcap.services.validation.plots import angles_png, bland_altman_png
from gaitcap.services.validation.report_pdf import validation_pdf
from gaitcap.services.validation.trial_data import load_trial

CSV_COLUMNS = ("section", "name", "side", "n", "bias", "sd", "loa_low", "loa_high", "icc", "mae", "signed_median",
               "abs_median", "missed", "extra", "rmse", "offset", "rmse_after_offset", "r", "unit")


def compare_files(trial_path: str | Path, reference_path: str | Path, *, stage: str | None = None,
                  config: ValidateConfig = ValidateConfig()) -> tuple[dict, dict]:
    """(result, angle curves for the overlay) of one pair (ValueError naming what is wrong)."""
    trial = load_trial(trial_path, stage)
    ref = read_reference(reference_path)
    result = validate(trial, ref, config=config)
    curves = {}
    lag = result["alignment"]["lag_s"]
    for a in result["angles"]:
        var, side = a["variable"], a["side"]
        b = interp_nan(trial.angle_times_s + lag, ref.times_s, ref.angles_deg[var][side])
        curves[(var, side)] = (trial.angle_times_s, trial.angles_deg[var][side], b)
    return result, curves


def csv_text(result: dict) -> str:
    buf = io.StringIO()
    w = csv.DictWriter(buf, CSV_COLUMNS, lineterminator="\n", extrasaction="ignore")
    w.writeheader()
    for e in result["events"]:
        w.writerow({"section": "event", "name": e["kind"], "side": e["side"], "n": e["n"],
                    "signed_median": e["signed_median_ms"], "abs_median": e["abs_median_ms"], "missed": e["missed"],
                    "extra": e["extra"], "unit": "ms"})
    for name, sides in result["parameters"].items():
        for side, s in sides.items():
            w.writerow({"section": "parameter", "name": name, "side": side, **s, "unit": name.rsplit("_", 1)[-1]})
    for name, v in result["trial_parameters"].items():
        w.writerow({"section": "trial_parameter", "name": name, "side": "all", "n": 1, "bias": v["difference"]})
    for a in result["angles"]:
        w.writerow({"section": "angle", "name": a["variable"], "side": a["side"], "n": a["n"], "rmse": a["rmse_deg"],
                    "offset": a["offset_deg"], "rmse_after_offset": a["rmse_after_offset_deg"], "r": a["r"],
                    "unit": "deg"})
    return buf.getvalue()


def write_validation(trial_path: str | Path, reference_path: str | Path, out: str | Path, *,
                     stage: str | None = None, config: ValidateConfig = ValidateConfig()) -> dict:
    """Compare the pair and write ``FILES`` into ``out``; the JSON-ready result. Nothing is written when
    the pair cannot be compared (the ValueError says why)."""
    result, curves = compare_files(trial_path, reference_path, stage=stage, config=config)
    result = json_ready(result)
    figures = {"bland_altman": bland_altman_png(result)} if result["step_pairs"] else {}
    if curves:
        figures["angles"] = angles_png(result, curves)
    blobs = {FILES["json"]: (json.dumps(result, indent=2) + "\n").encode(), FILES["csv"]: csv_text(result).encode(),
             FILES["pdf"]: validation_pdf(result, figures), **{FILES[k]: v for k, v in figures.items()}}
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    for name in FILES.values():  # a figure this pair has none of must not be left from an earlier run
        if name not in blobs and (out / name).exists():
            (out / name).unlink()
    for name, data in blobs.items():
        atomic_write_bytes(out / name, data)
    return result


def event_frames(result: dict) -> np.ndarray:
    """All matched heel-strike errors of a result (frames, trial's rate)."""
    fps = result["fps"]
    return np.array([(t - r) * fps for e in result["events"] if e["kind"] == "heel_strike"
                     for t, r in zip(e["trial_s"], e["reference_s"], strict=True)])
