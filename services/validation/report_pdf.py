"""The validation report a lab can file (A4, 1-2 pages, fpdf2 like the trial report): the pair, the
alignment found, the event table, the parameter agreement table, the angle table and the figures."""

from __future__ import annotations

import io
import math

from fpdf import FPDF
from gaitcap.services.reports.pdf import _latin1

KIND_NAMES = {"heel_strike": "heel strike", "toe_off": "toe off"}


def _f(x, d: int = 1) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.{d}f}"


def _table(pdf: FPDF, header: list[str], rows: list[list[str]], widths: list[float]) -> None:
    pdf.set_font("Helvetica", "B", 7.5)
    for h, w in zip(header, widths, strict=True):
        pdf.cell(w, 4.5, _latin1(h), border=1)
    pdf.ln()
    pdf.set_font("Helvetica", "", 7.5)
    for row in rows:
        for v, w in zip(row, widths, strict=True):
            pdf.cell(w, 4.2, _latin1(v), border=1)
        pdf.ln()
    pdf.ln(2)


def _heading(pdf: FPDF, text: str) -> None:
    pdf.set_font("Helvetica", "B", 10)
    pdf.cell(0, 6, _latin1(text), new_x="LMARGIN", new_y="NEXT")


def validation_pdf(result: dict, figures: dict[str, bytes]) -> bytes:
    """PDF bytes of ``result`` (``compare.validate``) with ``figures`` (name -> PNG bytes)."""
    pdf = FPDF(orientation="portrait", unit="mm", format="A4")
    pdf.set_auto_page_break(auto=True, margin=14)
    pdf.set_margins(14, 12, 14)
    pdf.add_page()
    pdf.set_font("Helvetica", "B", 13)
    pdf.cell(0, 8, "gaitcap validation against a reference recording", new_x="LMARGIN", new_y="NEXT")
    pdf.set_font("Helvetica", "", 8)
    a = result["alignment"]
    for line in (f"Trial: {result['trial']} (stage {result['stage']}, {result['fps']:.0f} fps)",
                 f"Reference: {result['reference']} ({result['reference_kind']})",
                 f"Alignment: {a['method']}; lag {a['lag_s']:+.3f} s ({a['lag_frames']:+.2f} frames)"
                 + (f", heel-height correlation {a['correlation']:.3f}" if "correlation" in a else "")
                 + f"; rotation {a['rotation_deg']:.1f} deg; residual {a['residual_mm']:.1f} mm",
                 f"Agreement: bias = mean(trial - reference), 95 % limits of agreement = bias +- 1.96 SD; "
                 f"{result['icc_form']}."):
        pdf.multi_cell(0, 4, _latin1(line), new_x="LMARGIN", new_y="NEXT")
    for line in result["not_compared"]:
        pdf.multi_cell(0, 4, _latin1(f"Not compared: {line}"), new_x="LMARGIN", new_y="NEXT")
    pdf.ln(2)
    if result["events"]:
        _heading(pdf, "Gait events (trial - reference)")
        rows = [[e["side"], KIND_NAMES[e["kind"]], str(e["n"]), _f(e["signed_median_ms"]), _f(e["abs_median_ms"]),
                 _f(e["signed_median_frames"], 2), _f(e["abs_median_frames"], 2), _f(e["abs_max_ms"]),
                 str(e["missed"]), str(e["extra"])] for e in result["events"]]
        _table(pdf, ["side", "event", "n", "signed med ms", "|e| med ms", "signed med fr", "|e| med fr",
                     "|e| max ms", "missed", "extra"], rows, [14, 20, 10, 22, 20, 22, 20, 20, 14, 14])
    if result["parameters"]:
        _heading(pdf, "Spatiotemporal parameters (both sides)")
        rows = []
        for name, sides in result["parameters"].items():
            s = sides["all"]
            rows.append([name, str(s["n"]), _f(s["trial_mean"]), _f(s["reference_mean"]), _f(s["bias"]),
                         f"{_f(s['loa_low'])} .. {_f(s['loa_high'])}", _f(s["icc"], 2), _f(s["mae"])])
        for name, v in result["trial_parameters"].items():
            rows.append([name, "1", _f(v["trial"], 2), _f(v["reference"], 2), _f(v["difference"], 2), "-", "-", "-"])
        _table(pdf, ["parameter", "n", "trial mean", "ref mean", "bias", "95 % LoA", "ICC(A,1)", "MAE"], rows,
               [38, 10, 22, 22, 20, 36, 18, 18])
    if result["angles"]:
        _heading(pdf, "Joint angles (degrees; offset = trial - reference)")
        rows = [[f"{x['side']} {x['variable']}", str(x["n"]), _f(x["rmse_deg"]), _f(x["offset_deg"]),
                 _f(x["rmse_after_offset_deg"]), _f(x["r"], 3), _f(x["trial_min_deg"]), _f(x["reference_min_deg"]),
                 str(len(x["cycles"]))] for x in result["angles"]]
        _table(pdf, ["angle", "n", "RMSE", "offset", "RMSE-offset", "r", "min trial", "min ref", "cycles"], rows,
               [42, 12, 16, 16, 20, 16, 18, 18, 14])
    for name in ("bland_altman", "angles"):
        if name in figures:
            if pdf.get_y() > 150:
                pdf.add_page()
            pdf.image(io.BytesIO(figures[name]), w=180)
    return bytes(pdf.output())
