"""Benchmark: the clinical report of a trial, from the stored results to the PDF.

Builds a catalog in a temporary folder with a patient's two visits (the synthetic walker, 10 s each, the
stored plot included), then times gathering the report's content (catalog, gait.json, norms, previous
visit) and rendering the PDF, and reports the PDF's size and pages.

    python bench/report_pdf.py                 # a table
    python bench/report_pdf.py --json          # one JSON object on stdout
    python bench/report_pdf.py --out r.pdf     # also keep the PDF

Timings are wall-clock on whatever machine runs it (noisy on shared CPUs).
"""

from __future__ import annotations

import argparse
import io
import statistics
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).parent))
from _common import emit  # noqa: E402


def _walk(step_mm: float):
    from gaitcap.reconstruction.gait import analyze_gait
    from gaitcap.reconstruction.skeletons import get_skeleton
    from gaitcap.simulator.params import WalkParams
    from gaitcap.simulator.path import Room, plan_walk
    from gaitcap.simulator.walker import simulate_body

    params, times = WalkParams(step_length_mm=step_mm), np.arange(300) / 30.0
    points, names = simulate_body(plan_walk(params, 10.0, Room(), seed=0), params, times), get_skeleton("halpe26").joint_names
    return points, times, list(names), analyze_gait(points, times, list(names))


def _trial(db, data_dir: Path, session: str, step_mm: float) -> str:
    from gaitcap.acquisition.fileio import atomic_write_text
    from gaitcap.services import catalog as cat
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.services.processing.outputs import steps_of, summary_of
    from gaitcap.services.processing.report_plot import heel_traces_png

    points, times, names, report = _walk(step_mm)
    trial = cat.start_trial(db, subject_id="P0042", session=session)
    cat.set_state(db, trial.id, "stopping")
    cat.set_state(db, trial.id, "recorded")
    files = trial_files(data_dir, trial.id)
    atomic_write_text(files.stage_file("refined", "gait_json"), report.to_json(indent=2))
    files.stage_file("refined", "report_png").write_bytes(heel_traces_png(report, points, times, names))
    cat.store_result(db, trial_id=trial.id, stage="refined", method="implicit_fit", steps=steps_of(report),
                     summary=summary_of(report), quality={}, report={"warnings": list(report.warnings)})
    return trial.id


def run(repeats: int, out: Path | None) -> dict:
    from gaitcap.services import catalog as cat
    from gaitcap.services.catalog import patients as pat
    from gaitcap.services.reports.content import report_content
    from gaitcap.services.reports.pdf import report_pdf
    from pypdf import PdfReader

    with tempfile.TemporaryDirectory() as tmp:
        data_dir = Path(tmp)
        db = cat.open_catalog(data_dir / "catalog.sqlite")
        _trial(db, data_dir, "visit-1", 600.0)
        tid = _trial(db, data_dir, "visit-2", 650.0)
        pat.update_patient(db, "P0042", sex="female", birth_year=1956)
        gather, render, pdf = [], [], b""
        for _ in range(repeats):
            t0 = time.perf_counter()
            content = report_content(db, data_dir, tid)
            t1 = time.perf_counter()
            pdf = report_pdf(content)
            gather.append(t1 - t0)
            render.append(time.perf_counter() - t1)
        db.close()
    if out is not None:
        out.write_bytes(pdf)
    return {"repeats": repeats, "gather_s_median": statistics.median(gather),
            "render_s_median": statistics.median(render), "render_s_max": max(render),
            "pdf_bytes": len(pdf), "pages": len(PdfReader(io.BytesIO(pdf)).pages)}


def _table(r: dict) -> str:
    return "\n".join([
        f"clinical report, median of {r['repeats']} runs",
        f"{'gather content (catalog, gait.json, norms, previous visit)':60s} {1000 * r['gather_s_median']:8.1f} ms",
        f"{'render the PDF (fpdf2)':60s} {1000 * r['render_s_median']:8.1f} ms (max {1000 * r['render_s_max']:.1f})",
        f"{'PDF size':60s} {r['pdf_bytes'] / 1024:8.1f} KiB",
        f"{'pages':60s} {r['pages']:8d}",
    ])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--repeats", type=int, default=10)
    ap.add_argument("--out", type=Path, default=None, help="write the last PDF here")
    ap.add_argument("--json", action="store_true")
    args = ap.parse_args()
    emit(run(args.repeats, args.out), as_json=args.json, table=_table)


if __name__ == "__main__":
    main()
