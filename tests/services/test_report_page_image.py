"""The report's first page as an image, compared with the reviewed reference
(``reference/report_page1.png``): a change of layout, fonts or content shows up as changed pixels.
After an intended change, look at the new page and write it with ``GAITCAP_UPDATE_REFERENCE=1``."""

import os
from pathlib import Path

import numpy as np
import pytest
from gaitcap.services.catalog.patients import PatientInfo, TrialDetailsInfo
from gaitcap.services.catalog.trials import TrialInfo
from gaitcap.services.reports.content import Footprint, ReportContent, flags_of, rows_of
from gaitcap.services.reports.norms import load_norms
from gaitcap.services.reports.pdf import report_pdf

REFERENCE = Path(__file__).parent / "reference" / "report_page1.png"
T0 = 1_780_000_000.0  # 2026-05-28 20:26:40 UTC
SUMMARY = {"num_steps": 14, "num_passes": 2, "gait_speed_m_s": 0.98, "cadence_steps_min": 104.2,
           "parameters": {"step_length_mm": {"all": {"n": 12, "mean": 565.0, "sd": 31.0, "cv_pct": 5.5},
                                             "left": {"mean": 540.0}, "right": {"mean": 590.0}},
                          "step_time_s": {"all": {"n": 12, "mean": 0.576, "sd": 0.08, "cv_pct": 13.9},
                                          "left": {"mean": 0.64}, "right": {"mean": 0.42}}},
           "asymmetry_pct": {"step_length_mm": 8.8, "step_time_s": 41.5}}


def _content() -> ReportContent:
    trial = TrialInfo("T20260528-202640-abc123", "P0042", "visit-2", "done", T0, T0 + 60, T0, T0 + 25, "", None,
                      "", 1.0, "")
    patient = PatientInfo("P0042", T0 - 86400 * 90, "female", 1956, "", 2)
    rows = rows_of(SUMMARY, load_norms(), sex="female", age=70)
    return ReportContent(
        clinic_name="Example Gait Clinic", trial=trial, patient=patient,
        details=TrialDetailsInfo(operator="alice", walking_aid="cane", footwear="own shoes"), age=70,
        stage="refined", method="implicit_fit", rows=rows, warnings=("Camera cam07 stopped at 4.2 s",),
        analysis_notes=("1 contact(s) in turns were not used as steps",), data_quality={"cameras": {}},
        footprints=tuple(Footprint("left" if i % 2 else "right", 560.0 * i, 50.0 if i % 2 else -50.0) for i in range(8)),
        heel_plot_png=None, norm_citations=load_norms().citations, version="test", num_steps=14, num_passes=2,
        flags=flags_of(rows))


def _page1(pdf: bytes) -> np.ndarray:
    pdfium = pytest.importorskip("pypdfium2", reason="pypdfium2 (dev extra) renders the page")
    page = pdfium.PdfDocument(pdf)[0]
    return np.asarray(page.render(scale=1.0).to_pil().convert("L"), dtype=np.int16)


def test_first_page_matches_the_reviewed_reference():
    from PIL import Image

    image = _page1(report_pdf(_content()))
    if os.environ.get("GAITCAP_UPDATE_REFERENCE") == "1":  # writes the reference; compares nothing
        Image.fromarray(image.astype(np.uint8)).save(REFERENCE)
        pytest.skip(f"{REFERENCE.name} written: look at it, then run again without GAITCAP_UPDATE_REFERENCE")
    reference = np.asarray(Image.open(REFERENCE).convert("L"), dtype=np.int16)
    assert image.shape == reference.shape
    changed = np.abs(image - reference) > 64
    assert changed.mean() < 0.002, f"{changed.sum()} pixels differ from {REFERENCE.name}"


def test_the_comparison_sees_a_changed_page():
    image = _page1(report_pdf(_content()))
    other = _content()
    other = ReportContent(**{**other.__dict__, "flags": ()})  # the findings section changes
    changed = np.abs(image - _page1(report_pdf(other))) > 64
    assert changed.mean() >= 0.002
