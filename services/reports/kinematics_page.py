"""The report's joint kinematics: a page with the gait-cycle curves of each side over the normal band
chosen for the patient's age (with its source), and the key clinical values (mean +- SD per side, and the
same value read off the band's mean curve); or a line saying why there are none."""

from __future__ import annotations

import io

from fpdf.fonts import FontFace
from gaitcap.reconstruction.kinematics.clinical import DEFAULT_TOE_OFF_PCT, KEY_VALUES, key_label
from gaitcap.reconstruction.kinematics.key_norms import (
    NO_REFERENCE,
    UNVALIDATED_ZERO,
    key_norms,
    no_reference,
)
from gaitcap.services.reports.shown import KEY_VALUE_DECIMALS, key_norm_shown, shown

NORMAL_NOTE = (f"Normal: the key value read off the band's mean curve (toe-off taken at {DEFAULT_TOE_OFF_PCT:.0f} % "
               "of the cycle); Normal (95 %): +- 1.96 times the band's SD where the value is read; a range of "
               "motion (whatever the angle's zero) against the band's range: no SD, only a lower limit "
               "(range - 1.96 (SD at the band's peak + SD at its dip)). Signed values: the convention is in the "
               "label. !: outside the normal range (|z| > 1.96, or a range below its lower limit).")


def _stat(s: dict | None) -> str:
    """mean +- SD (n), with the one rounding rule (:mod:`gaitcap.services.reports.shown`, as on the page)."""
    mean = shown(s.get("mean"), KEY_VALUE_DECIMALS) if isinstance(s, dict) else None
    if mean is None:
        return "-"
    sd = shown(s.get("sd"), KEY_VALUE_DECIMALS)
    return mean + (f" \u00b1 {sd}" if sd is not None else "") + f" (n={s.get('n', '?')})"


def _side_cell(s: dict | None, norm) -> str:
    """The side's value, marked "!" when outside the normal range (:meth:`KeyNorm.verdict`)."""
    text = _stat(s)
    value = s.get("mean") if isinstance(s, dict) else None
    off = norm.verdict(float(value)) if norm is not None and isinstance(value, (int, float)) else 0
    return text + (" !" if off else "")


def _range_cell(name: str, norm) -> str:
    """The normal range; without one why: the angle's zero not validated ("no reference"), or no band."""
    if norm is None:
        return "no reference" if no_reference(name) else "no band"
    said = key_norm_shown(norm)
    return f"{said['normal_range'][0]} to {said['normal_range'][1]}" if said["normal_range"] else f"at least {said['lower_limit']}"


def _key_table(pdf, k: dict) -> None:
    kv, bands = k.get("key_values") or {}, (k.get("norms") or {}).get("bands") or {}
    names = [n for n in (kv.get("left") or {}) if any(((kv.get(s) or {}).get(n) or {}).get("n") for s in kv)]
    if not names:
        pdf.para("No key values: no complete gait cycle.")
        return
    norms = key_norms(bands)
    patient_none = (k.get("norms") or {}).get("no_reference") or ""
    heads, widths = ("Key value (degrees)", "Left", "Right", "Normal", "Normal (95 %)"), (56, 32, 32, 16, 28)
    if patient_none:  # no band for this patient: no normal columns, one sentence under the table
        heads, widths = heads[:3], widths[:3]
    pdf.set_font("Helvetica", "", 8)
    with pdf.table(col_widths=widths, width=sum(widths), align="LEFT", line_height=4.0,
                   text_align=("LEFT",) + ("RIGHT",) * (len(heads) - 1),
                   headings_style=FontFace(emphasis="BOLD", fill_color=(230, 234, 240))) as table:
        head = table.row()
        for h in heads:
            head.cell(h)
        for name in names:
            row = table.row()
            norm = norms.get(name)
            row.cell(pdf.latin1(key_label(name)))
            for side in ("left", "right"):
                row.cell(pdf.latin1(_side_cell((kv.get(side) or {}).get(name), norm)))
            if not patient_none:
                row.cell(key_norm_shown(norm)["normal"] or "-" if norm is not None else "-")
                row.cell(pdf.latin1(_range_cell(name, norm)))
    if patient_none:
        pdf.para("Normal: no reference for this patient (see the band above); signed values: the convention is in "
                 "the label.", 7, height=3.3)
        return
    unvalidated = {KEY_VALUES[n][0] for n in names if no_reference(n)} if bands else set()
    why = "; ".join(f"{var.replace('_', ' ')}: {UNVALIDATED_ZERO[var]}" for var in sorted(unvalidated))
    pdf.para(NORMAL_NOTE + (f" {NO_REFERENCE[0].upper()}{NO_REFERENCE[1:]} ({why})." if why else ""), 7, height=3.3)


def _notes(k: dict) -> list[str]:
    norms = k.get("norms") or {}
    if norms.get("no_reference"):
        no_ref = norms["no_reference"]
        return [f"No normal band: {no_ref[0].upper()}{no_ref[1:]}."] + [
            f"{name.replace('_', ' ').capitalize()}: not measured ({why})." for name, why in
            (k.get("not_measured") or {}).items()] + [f"Warning: {w}." for w in k.get("warnings") or []]
    out = [f"Grey band: normal mean +- 1 SD for {norms.get('population')}. Source: {norms['source']}."
           if norms.get("source") else "No normal band: no normative data is installed."]
    missing = {name: why for name, why in (norms.get("missing") or {}).items() if name in (k.get("curves") or {})}
    for why in dict.fromkeys(missing.values()):
        names = ", ".join(n.replace("_", " ") for n, w in missing.items() if w == why)
        out.append(f"No band (not drawn): {names} ({why}).")
    for name, why in (norms.get("not_drawn") or {}).items():
        if name in (k.get("curves") or {}):
            out.append(f"{name.replace('_', ' ').capitalize()}: {why}.")
    out += [f"{name.replace('_', ' ').capitalize()}: not measured ({why})." for name, why in
            (k.get("not_measured") or {}).items()]
    return out + [f"Warning: {w}." for w in k.get("warnings") or []]


def gait_profile_line(k: dict) -> str:
    """The Gait Profile Score over the variables it could include, naming those it could not."""
    from gaitcap.reconstruction.kinematics.gait_profile import gait_profile

    p = gait_profile(k)
    included = sorted({v for side in p.gvs_deg.values() for v in side})
    if not included:
        why = ("no reference for this patient" if (k.get("norms") or {}).get("no_reference")
               else "no measured angle has a normal band")
        return f"Gait Profile Score (Baker 2009): not computed ({why})."
    left_out = "; ".join(f"{v.replace('_', ' ')} {why}" for v, why in p.not_included.items())
    return (f"Gait Profile Score (Baker 2009) over {', '.join(v.replace('_', ' ') for v in included)} only: left "
            f"{p.gps_deg['left']:.1f}, right {p.gps_deg['right']:.1f}, both {p.overall_gps_deg:.1f} deg (not Baker's "
            f"nine-variable score; left out: {left_out}).")


SAGITTAL = ("hip_flexion", "knee_flexion", "ankle_dorsiflexion")  # the curves of the key values read at a point


def kinematics_figure_png(k: dict) -> bytes | None:
    """The report's curves: each side's mean +- SD over the band, of the variables that have a band (the
    others are named in the notes; with no band for this patient, the sagittal hip, knee and ankle),
    half a page wide; None without curves."""
    from gaitcap.services.kinematics.plot import side_curves_png

    curves, bands = k.get("curves") or {}, (k.get("norms") or {}).get("bands") or {}
    shown = ({name: c for name, c in curves.items() if name in bands}
             or {name: c for name, c in curves.items() if name in SAGITTAL} or curves)
    if not shown:
        return None
    return side_curves_png({**k, "curves": shown}, width_in=8.0)


def kinematics_section(pdf) -> None:
    """The key values against the band with the band's source and what has no band; the curves are drawn
    beside the heel traces (``pdf.curves_drawn``), else on their own here (``pdf.c``: the report content)."""
    c = pdf.c
    k = c.kinematics or {}
    if k.get("curves"):
        pdf.heading("Joint kinematics (mean +- SD per side; left blue, right red; grey: the normal band)", keep_mm=40)
        if not getattr(pdf, "curves_drawn", False):
            png = kinematics_figure_png(k)
            if png:
                pdf.image(io.BytesIO(png), w=(pdf.w - pdf.l_margin - pdf.r_margin) / 2)
        pdf.para(" ".join(_notes(k) + [gait_profile_line(k)]), 7, height=3.3)
    else:
        pdf.heading("Joint angles")
    if k.get("key_values"):
        _key_table(pdf, k)
    if c.joint_angles_note and not k.get("curves"):
        pdf.para(c.joint_angles_note)
    elif not k.get("key_values"):
        pdf.para(c.joint_angles_note or "No joint kinematics.")
