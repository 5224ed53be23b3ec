"""The trial's report as an A4 PDF for the patient's chart (fpdf2: pure Python, small, vector text and
tables; the heel-trace figure is the stored plot, the step diagram is drawn as vector shapes).

Page 1: clinic, patient, date, session, clinical fields, data quality, the parameter table (left, right,
mean, SD, CV, symmetry, normal range, z-score and percentile, the previous visit), flags. Page 2: the
heel-trace figure, the footprints; the joint kinematics (a page of curves and key values when computed,
services/reports/kinematics_page.py); method, version, sources, signature.
"""

from __future__ import annotations

import io
import math
import time
from dataclasses import dataclass

from fpdf import FPDF
from fpdf.fonts import FontFace
from gaitcap.services.reports.content import METHOD_TEXT, PARAMETERS, ReportContent, Row
from gaitcap.services.reports.kinematics_page import kinematics_figure_png, kinematics_section
from gaitcap.services.reports.shown import shown, shown_signed

SIDE_COLOURS = {"left": (31, 119, 180), "right": (214, 39, 40)}


def _latin1(text: str) -> str:
    """The core PDF fonts are Latin-1: other characters become their closest plain form."""
    text = str(text).replace("\u2013", "-").replace("\u2014", "-").replace("\u2212", "-").replace("\u2026", "...")
    return text.encode("latin-1", "replace").decode("latin-1")


def _fmt(x: float, decimals: int) -> str:
    """The stored value as the page shows it (one rounding rule, services/reports/shown.py); "-" if none."""
    return shown(x, decimals) or "-"


def ordinal(n: int) -> str:
    """1st, 2nd, 3rd, 4th, 11th, 12th, 13th, 21st, 41st, 43rd, 61st."""
    suffix = "th" if 10 <= n % 100 <= 20 else {1: "st", 2: "nd", 3: "rd"}.get(n % 10, "th")
    return f"{n}{suffix}"


def _when(t_s: float | None) -> str:
    return time.strftime("%Y-%m-%d %H:%M UTC", time.gmtime(t_s)) if t_s else "-"


class _Doc(FPDF):
    latin1 = staticmethod(_latin1)

    def __init__(self, c: ReportContent, layout: Layout | None = None, figures: dict | None = None) -> None:
        super().__init__(orientation="portrait", unit="mm", format="A4")
        self.c = c
        self.layout = layout or LAYOUTS[0]
        self.figures = {} if figures is None else figures  # drawn once, kept over the layouts tried
        self.set_auto_page_break(auto=True, margin=16)
        self.set_margins(14, 12, 14)
        self.set_title(f"Gait report {c.patient.id} {c.trial.id}")
        self.set_creator(f"gaitcap {c.version}")

    def figure(self, key: str, make) -> bytes | None:
        """The figure ``key`` (PNG bytes, or None), made by ``make()`` the first time it is asked for."""
        if key not in self.figures:
            self.figures[key] = make()
        return self.figures[key]

    def header(self) -> None:
        self.set_font("Helvetica", "B", 13)
        self.cell(0, 7, _latin1(self.c.clinic_name), new_x="LMARGIN", new_y="NEXT")
        self.set_font("Helvetica", "", 9)
        self.cell(0, 5, _latin1(f"Gait analysis report - patient {self.c.patient.id} ({_sex_age(self.c)}) - "
                                f"{_when(self.c.trial.started_at)}"), new_x="LMARGIN", new_y="NEXT")
        self.line(self.l_margin, self.get_y() + 1, self.w - self.r_margin, self.get_y() + 1)
        self.ln(3)
        if self.c.details.voided:  # on every page: a page printed alone must not look valid
            self.set_text_color(160, 0, 0)
            self.set_font("Helvetica", "B", 12)
            reason = self.c.details.void_reason
            reason = reason if len(reason) <= 70 else reason[:69] + "..."
            self.cell(0, 6, _latin1(f"VOID - not for clinical use: {reason}"),
                      new_x="LMARGIN", new_y="NEXT")
            self.set_text_color(0, 0, 0)
            self.set_font("Helvetica", "", 9)

    def footer(self) -> None:
        self.set_y(-12)
        self.set_font("Helvetica", "", 8)
        self.cell(0, 5, _latin1(f"Trial {self.c.trial.id} - gaitcap {self.c.version} - page {self.page_no()}/{{nb}}"),
                  align="C")

    curves_drawn = False  # the joint-angle curves are on the page already (beside the heel traces)

    def heading(self, text: str, keep_mm: float = 16.0) -> None:
        """A section heading, on the next page when less than ``keep_mm`` is left under it (no heading
        alone at the bottom of a page)."""
        if self.get_y() + 1.5 + 6 + keep_mm > self.page_break_trigger:
            self.add_page()
        self.ln(1.5)
        self.set_font("Helvetica", "B", 11)
        self.cell(0, 6, _latin1(text), new_x="LMARGIN", new_y="NEXT")
        self.set_font("Helvetica", "", 9)

    def para(self, text: str, size: float = 9, style: str = "", height: float = 4.4) -> None:
        self.set_font("Helvetica", style, size)
        self.multi_cell(0, height, _latin1(text), new_x="LMARGIN", new_y="NEXT")


def _sex_age(c: ReportContent) -> str:
    """"female, 74 years"; what is not recorded says so ("sex not recorded, age not recorded")."""
    return ", ".join((c.patient.sex or "sex not recorded",
                      f"{c.age} years" if c.age is not None else "age not recorded"))


def _identity(pdf: _Doc) -> None:
    c, d = pdf.c, pdf.c.details
    pairs = [("Patient ID", c.patient.id), ("Sex, age", _sex_age(c)), ("Date and time", _when(c.trial.started_at)),
             ("Session", c.trial.session), ("Trial", c.trial.id), ("Operator", d.operator or "-"),
             ("Walking aid", d.walking_aid or "none recorded"), ("Assistance", d.assistance or "none recorded"),
             ("Footwear", d.footwear or "not recorded"), ("Results", f"{c.stage} ({c.method})")]
    pdf.set_font("Helvetica", "", 9)
    with pdf.table(col_widths=(28, 62, 28, 62), first_row_as_headings=False, line_height=5,
                   borders_layout="NONE") as table:
        for i in range(0, len(pairs), 2):
            row = table.row()
            for label, value in pairs[i:i + 2]:
                row.cell(_latin1(label), style=FontFace(emphasis="BOLD"))
                row.cell(_latin1(value))
    if d.notes:
        pdf.para(f"Notes: {d.notes}")
    if d.voided:
        pdf.set_text_color(160, 0, 0)
        pdf.para(f"VOID: {d.void_reason} (by {d.voided_by}, {_when(d.voided_at)}). Not for clinical use.", 11, "B")
        pdf.set_text_color(0, 0, 0)


def _quality(pdf: _Doc) -> None:
    c = pdf.c
    pdf.heading("Data quality")
    if c.warnings:
        pdf.set_text_color(140, 70, 0)
        for w in c.warnings:
            pdf.para(f"- {w}")
        pdf.set_text_color(0, 0, 0)
    elif c.data_quality:
        pdf.para("No data-quality warnings: every camera, the synchronisation and the coverage met the criteria.")
    else:
        pdf.para("The data quality was not measured for this trial (no cameras' record).")
    pdf.para(f"{c.num_steps} step{'s' * (c.num_steps != 1)} in {c.num_passes} straight "
             f"pass{'es' * (c.num_passes != 1)} analysed."
             + (" Notes of the analysis: " + "; ".join(c.analysis_notes) + "." if c.analysis_notes else ""))


def _norm_cells(r: Row) -> tuple[str, str]:
    if r.norm is None:
        return "no reference", "-"
    p = PARAMETERS[r.name]
    lo, hi = r.norm.band()
    z = r.z
    return (f"{_fmt(lo, p.decimals)}-{_fmt(hi, p.decimals)}",
            f"{shown_signed(z, 1)} ({ordinal(round(r.percentile))})" if math.isfinite(z) else "-")


def _table(pdf: _Doc) -> None:
    c = pdf.c
    pdf.heading("Spatiotemporal parameters (steady steps; left / right / both)")
    heads = ["Parameter", "Left", "Right", "Mean", "SD", "CV %", "SI %", "Normal (95 %)", "z (pct)"]
    widths = [40, 15, 15, 15, 13, 12, 12, 26, 20]
    if c.previous is not None:
        heads.append("Previous")
        widths.append(18)
    pdf.set_font("Helvetica", "", 8.5)
    with pdf.table(col_widths=tuple(widths), line_height=4.6, text_align=("LEFT",) + ("RIGHT",) * (len(heads) - 1),
                   headings_style=FontFace(emphasis="BOLD", fill_color=(230, 234, 240))) as table:
        head = table.row()
        for h in heads:
            head.cell(h)
        for r in c.rows:
            p = PARAMETERS[r.name]
            row = table.row()
            row.cell(_latin1(f"{p.label} ({p.unit})"))
            for value, dec in ((r.left, p.decimals), (r.right, p.decimals), (r.mean, p.decimals),
                               (r.sd, p.decimals + 1), (r.cv_pct, 1), (r.si_pct, 1)):
                row.cell(_fmt(value, dec))
            for text in _norm_cells(r):
                row.cell(_latin1(text))
            if c.previous is not None:
                row.cell(_fmt(c.previous.values.get(r.name, math.nan), p.decimals))
    pdf.set_font("Helvetica", "", 7.5)
    note = ("SI: symmetry index, 100 |L - R| / mean of L and R (0 = symmetric). z: (mean - normative mean) / "
            "normative SD; pct: its percentile. Normal: normative mean +- 1.96 SD for the patient's age group "
            "and sex; 'no reference' where the normative table has no row (or sex or birth year not recorded).")
    if c.previous is not None:
        note += f" Previous: trial {c.previous.trial.id}, session {c.previous.trial.session}, {_when(c.previous.trial.started_at)}."
    pdf.multi_cell(0, 3.6, _latin1(note), new_x="LMARGIN", new_y="NEXT")


def _flags(pdf: _Doc) -> None:
    c = pdf.c
    pdf.heading("Findings to note")
    if c.norm_summary:
        pdf.para(c.norm_summary)
    if c.speed_reference:
        pdf.para(c.speed_reference["text"])
    for f in c.flags:
        pdf.para(f"- {f}")
    if not c.flags:
        pdf.para("No finding to note" + (" against a normal range" if "none outside" in c.norm_summary else "")
                 + "; no side difference over 10 %" + (" that holds over the steps" if c.withheld else "")
                 + (" among the parameters without a data problem." if c.data_problems else "."))
    for w in c.withheld:  # numbers stated, no finding: too few steps, or gone when one step is left out
        pdf.para(f"- {w}")
    if c.data_problems:
        pdf.set_text_color(140, 70, 0)
        for p in c.data_problems:
            pdf.para(f"- {p}")
        pdf.set_text_color(0, 0, 0)


def _figures(pdf: _Doc) -> None:
    """The heel traces and, beside them, the joint-angle curves (the variables with a band), both half the
    page wide, so that one trial's report stays on two pages."""
    c = pdf.c
    curves = pdf.figure("curves", lambda: _compact(kinematics_figure_png(c.kinematics or {})))
    left_out = bool(curves) and not pdf.layout.curves
    if left_out:
        curves = None
        pdf.curves_drawn = True  # not drawn on their own further down either: said here
    pdf.heading("Heel traces and detected steps" + (" | joint angles over the gait cycle" if curves else ""),
                keep_mm=60)
    if left_out:
        pdf.para("The joint-angle curves are on the clinic page (left out here to keep the report on two pages).", 7)
    half = (pdf.w - pdf.l_margin - pdf.r_margin - 4) / 2 * pdf.layout.figures
    y0, bottom = pdf.get_y(), pdf.get_y()
    heel = pdf.figure("heel", lambda: _compact(c.heel_plot_png))
    if heel:
        info = pdf.image(io.BytesIO(heel), x=pdf.l_margin, y=y0, w=half if curves else 120 * pdf.layout.figures)
        bottom = max(bottom, y0 + info.rendered_height)
    else:
        pdf.para("The heel-trace figure was not written for this trial.")
        bottom = pdf.get_y()
    if curves:
        info = pdf.image(io.BytesIO(curves), x=pdf.l_margin + half + 4, y=y0, w=half)
        bottom = max(bottom, y0 + info.rendered_height)
        pdf.curves_drawn = True
    pdf.set_y(bottom + 1)


def _footprints(pdf: _Doc) -> None:
    c = pdf.c
    pdf.heading("Footprints of the first straight pass (walking direction to the right)", keep_mm=26)
    if not c.footprints:
        pdf.para("Fewer than two steps in the first pass: no footprint diagram.")
        return
    span = max(f.along_mm for f in c.footprints) - min(f.along_mm for f in c.footprints) or 1.0
    width = pdf.w - pdf.l_margin - pdf.r_margin - 10
    scale = min(width / span, 0.12)  # mm on paper per mm on the floor
    x0, y0 = pdf.l_margin + 5, pdf.get_y() + 8
    pdf.set_draw_color(180, 180, 180)
    pdf.line(x0, y0, x0 + span * scale, y0)
    for f in c.footprints:
        pdf.set_fill_color(*SIDE_COLOURS.get(f.side, (90, 90, 90)))
        x, y = x0 + f.along_mm * scale, y0 - f.across_mm * scale
        pdf.ellipse(x - 3.2, y - 1.6, 6.4, 3.2, style="F")
    pdf.set_draw_color(0, 0, 0)
    pdf.set_fill_color(255, 255, 255)  # the tables after it are not filled with the last foot's colour
    pdf.set_y(y0 + 8)
    pdf.set_font("Helvetica", "", 8)
    pdf.cell(0, 4, _latin1(f"Blue: left heel, red: right heel; scale 1:{1 / scale:.0f}; {span / 1000:.2f} m shown."),
             new_x="LMARGIN", new_y="NEXT")


def _validation(pdf: _Doc) -> None:
    """The trial's agreement with the lab's reference recording (``gaitcap validate``), when it has one: the
    same rows as the page's validation section (services/validation/shown_rows.py)."""
    v = pdf.c.validation
    if not v:
        return
    small = pdf.layout.small_pt
    pdf.heading("Agreement with the lab's reference (gaitcap validate; gaitcap minus reference)", keep_mm=14)
    pdf.para(v["alignment"], small + 1, height=small * 0.5)
    pdf.set_font("Helvetica", "", small)
    for row in v["rows"]:
        pdf.cell(38, small * 0.5, _latin1(row["what"]))
        pdf.cell(10, small * 0.5, str(row["n"]))
        pdf.cell(100, small * 0.5, _latin1(row["difference"]))
        pdf.cell(0, small * 0.5, _latin1(row["agreement"]), new_x="LMARGIN", new_y="NEXT")
    for note in v["not_compared"]:
        pdf.para(note, small, height=small * 0.47)


def _closing(pdf: _Doc) -> None:
    c = pdf.c
    kinematics_section(pdf)
    _validation(pdf)
    pdf.heading("Method and software", keep_mm=14)
    small = pdf.layout.small_pt
    pdf.para(f"{METHOD_TEXT} Software: gaitcap {c.version}; results: {c.stage} ({c.method}).", small,
             height=small * 0.47)
    pdf.heading("Normative reference", keep_mm=14)
    pdf.para(" ".join(c.norm_citations) or "No normative table.", small, height=small * 0.47)
    if pdf.get_y() + 14 > pdf.page_break_trigger:
        pdf.add_page()
    pdf.ln(6)
    pdf.set_font("Helvetica", "", 10)
    pdf.cell(95, 6, "Clinician: ______________________________")
    pdf.cell(0, 6, "Signature / date: ______________________", new_x="LMARGIN", new_y="NEXT")


SECTIONS = (_identity, _quality, _table, _flags, _figures, _footprints, _closing)


@dataclass(frozen=True)
class Layout:
    """How much room the report's second page gives: ``figures`` scales the figures' width, ``small_pt``
    is the size (pt) of the method and source notes, ``curves`` whether the joint-angle curves are drawn."""

    figures: float = 1.0
    small_pt: float = 7.0
    curves: bool = True


#: tried in order until the report fits on ``MAX_PAGES`` pages (the last one is used whatever its length)
LAYOUTS = (Layout(), Layout(figures=0.8, small_pt=6.0), Layout(figures=0.8, small_pt=6.0, curves=False))
MAX_PAGES = 2
PNG_COLOURS = 64  # the figures' palette in the PDF: a third of the bytes of the full-colour plot, lines as sharp


def _compact(png: bytes | None) -> bytes | None:
    """A plot (PNG) with a palette of :data:`PNG_COLOURS` colours, so that a report stays near 100 kB."""
    if not png:
        return None
    from PIL import Image

    out = io.BytesIO()
    Image.open(io.BytesIO(png)).convert("RGB").quantize(colors=PNG_COLOURS).save(out, "PNG", optimize=True)
    return out.getvalue()


def _render(content: ReportContent, layout: Layout, figures: dict) -> _Doc:
    pdf = _Doc(content, layout, figures)
    pdf.alias_nb_pages()
    pdf.add_page()
    for section in SECTIONS:
        if section is _figures:
            pdf.add_page()
        section(pdf)
    return pdf


def report_pdf(content: ReportContent) -> bytes:
    """The report as PDF bytes, on at most :data:`MAX_PAGES` A4 pages: the first of :data:`LAYOUTS` that
    fits (smaller figures and notes, then the joint-angle curves left out, saying so)."""
    figures: dict = {}  # each figure drawn and compacted once, whatever the layouts tried
    for layout in LAYOUTS:
        pdf = _render(content, layout, figures)
        if pdf.pages_count <= MAX_PAGES:
            break
    return bytes(pdf.output())
