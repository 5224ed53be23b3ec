"""Sweep grids (JSON and TOML) and the sweep table in the paper's appendix layout, computed on synthetic
trials with ground truth: robust triangulation variants, plain triangulation and a short explicit fit."""

import csv
import json

import pytest
from gaitcap.services.cli import app
from gaitcap.services.research.sweep import COLUMNS, load_grid
from typer.testing import CliRunner

from .reprocess_trials import make_walks, recorded_catalog

GRID_TOML = """
[[methods]]
method = "robust"
label = "Robust Triangulation"
grid = { sigma_mm = [100, 150] }

[[methods]]
method = "dlt"
label = "Triangulation"

[[methods]]
method = "explicit"
label = "Explicit"
params = { iterations = 15, huber_cut_px = "none" }
"""


def test_grids_expand_to_typed_method_specs(tmp_path):
    path = tmp_path / "grid.json"
    path.write_text(json.dumps({"methods": [
        {"method": "robust", "grid": {"gamma": [0.3, 0.5], "sigma_mm": [50, 100, 150]}},
        {"method": "implicit", "label": "Implicit", "params": {"iterations": 20},
         "grid": {"use_confidence": [False, True], "huber_cut_px": ["none", 10]}}]}))
    specs = load_grid(path)
    assert len(specs) == 6 + 4 and len({s.key for s in specs}) == 10
    assert specs[0].name == "robust gamma=0.3 sigma_mm=50" and specs[0].config().gamma == 0.3
    last = specs[-1]
    assert last.name == "Implicit use_confidence=true huber_cut_px=10"
    cfg = last.config()
    assert cfg.use_confidence and cfg.fit.loss.cut_px == 10.0 and cfg.fit.solver.iterations == 20
    assert specs[6].config().fit.loss.cut_px is None
    toml = tmp_path / "grid.toml"
    toml.write_text(GRID_TOML)
    assert [s.name for s in load_grid(toml)] == ["Robust Triangulation sigma_mm=100",
                                                 "Robust Triangulation sigma_mm=150", "Triangulation", "Explicit"]
    for bad, words in (({"methods": []}, "non-empty 'methods'"),
                       ({"methods": [{"method": "robust", "gird": {}}]}, "methods[0]: unknown field(s) ['gird']"),
                       ({"methods": [{"method": "robust", "grid": {"gamma": 0.3}}]}, "grid.gamma: must be a non-empty list"),
                       ({"methods": [{"method": "dlt"}, {"method": "robust", "grid": {"sigma": [1]}}]},
                        "methods[1]: method robust: unknown parameter 'sigma'")):
        path.write_text(json.dumps(bad))
        with pytest.raises(ValueError, match=words.replace("[", r"\[").replace("]", r"\]").replace("(", r"\(").replace(")", r"\)")):
            load_grid(path)


def test_sweep_writes_the_appendix_table(tmp_path):
    data = tmp_path / "data"
    db, ids = recorded_catalog(data, make_walks(2))
    (tmp_path / "grid.toml").write_text(GRID_TOML)
    out = tmp_path / "out"
    result = CliRunner().invoke(app, ["sweep", "--grid", str(tmp_path / "grid.toml"), "--data-dir", str(data),
                                      "--out", str(out), "--workers", "0"])
    assert result.exit_code == 0, result.output
    rows = list(csv.DictReader(open(out / "sweep.csv")))
    assert list(rows[0]) == [c for c, _, _ in COLUMNS]
    assert [r["method"] for r in rows] == ["Robust Triangulation sigma_mm=100", "Robust Triangulation sigma_mm=150",
                                           "Triangulation", "Explicit"]
    num = [{k: float(v) for k, v in r.items() if k not in ("keypoints", "method", "reference", "params_key")} for r in rows]
    for r, n in zip(rows, num, strict=True):
        assert r["keypoints"] == "halpe26" and r["reference"] == "ground truth" and n["trials"] == 2
        assert 0 < n["GC_5"] < n["GC_10"] < n["GC_20"] <= 1 and n["footfalls"] >= 10
        assert 0 < n["step_width_mm"] < 25 and 0 < n["heel_lateral_mm"] < 25, r
    robust, dlt, fit = num[1], num[2], num[3]
    assert robust["GC_10"] > dlt["GC_10"] and robust["MPJPE"] < dlt["MPJPE"]
    assert fit["L_skeleton"] < robust["L_skeleton"] / 5 and fit["L_smooth"] < 0.6 * robust["L_smooth"]
    md = (out / "sweep.md").read_text()
    assert md.startswith("| Keypoints | Method | GC_5 | GC_10 | GC_20 | L_reproj (px) | L_skeleton (mm)")
    assert "| halpe26 | Explicit |" in md and "sigma_IQR" in md
    assert json.loads((out / "sweep.json").read_text())["rows"][3]["method"] == "Explicit"
    again = CliRunner().invoke(app, ["sweep", "--grid", str(tmp_path / "grid.toml"), "--data-dir", str(data),
                                     "--out", str(out), "--workers", "0"])
    assert again.exit_code == 0 and "8 already done, 0 to compute" in again.output
