"""What a trial's clinical report says, gathered from the stored results: the catalog (trial, patient,
clinical fields, data-quality warnings, the result) and the stage's ``gait.json`` (per-side statistics,
symmetry indices, step positions, the analysis's notes). Rendering is :mod:`gaitcap.services.reports.pdf`."""

from __future__ import annotations

import json
import math
import os
from dataclasses import dataclass, field
from pathlib import Path

from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat
from gaitcap.services.processing.artifacts import trial_files
from gaitcap.services.reports.findings import (
    Findings,
    consistency_of,
    findings_of,
    key_value_findings,
    outage_problem,
)
from gaitcap.services.reports.norms import NormRow, NormTable, load_norms, missing_for_patient, percentile
from gaitcap.services.reports.speed_means import compare_speed
from gaitcap.services.validation.shown_rows import shown_validation, stored_validation


@dataclass(frozen=True)
class Parameter:
    """How a parameter is shown: label, unit, decimals and a one-line help (what it is, how measured)."""

    label: str
    unit: str
    decimals: int
    help: str


#: Report parameters in order: gait.json name -> how it is shown. Lengths mm, times s, % of the gait cycle.
PARAMETERS: dict[str, Parameter] = {
    "gait_speed_m_s": Parameter("Gait speed", "m/s", 2, "Total stride length / total stride time of the "
                                "steady steps."),
    "cadence_steps_min": Parameter("Cadence", "steps/min", 1, "60 / mean step time."),
    "step_length_mm": Parameter("Step length", "mm", 0, "Previous opposite heel contact to this heel "
                                "contact, along the walking direction."),
    "stride_length_mm": Parameter("Stride length", "mm", 0, "Previous heel contact of the same foot to this "
                                  "one, along the walking direction."),
    "step_width_mm": Parameter("Step width", "mm", 0, "Sideways distance of a heel contact from the line of "
                               "the other foot's contacts (base of support)."),
    "step_time_s": Parameter("Step time", "s", 2, "Time since the opposite foot's heel strike."),
    "stride_time_s": Parameter("Stride time", "s", 2, "Time since this foot's previous heel strike."),
    "stance_time_s": Parameter("Stance time", "s", 2, "Heel strike to toe off of the same foot."),
    "swing_time_s": Parameter("Swing time", "s", 2, "Toe off to the next heel strike of the same foot."),
    "single_support_s": Parameter("Single support", "s", 2, "Time on this foot alone (the other foot's swing)."),
    "double_support_s": Parameter("Double support", "s", 2, "Time with both feet on the floor in the cycle."),
    "stance_pct": Parameter("Stance", "% cycle", 1, "Stance time as % of stride time."),
    "swing_pct": Parameter("Swing", "% cycle", 1, "Swing time as % of stride time."),
    "single_support_pct": Parameter("Single support", "% cycle", 1, "Single support as % of stride time."),
    "double_support_pct": Parameter("Double support", "% cycle", 1, "Double support as % of stride time."),
}

#: parameter -> unit: what a normative CSV's rows must use.
NORM_UNITS = {name: p.unit for name, p in PARAMETERS.items()}

METHOD_TEXT = ("Markerless multi-camera 3D pose: 2D keypoints per camera, robust triangulation, then a "
               "smooth implicit fit (refined results); heel strikes and toe offs from foot speed and "
               "position; statistics over the steady steps of straight passes (edge steps excluded); "
               "symmetry index SI = 100 |L - R| / (0.5 (L + R)) (Robinson, Herzog & Nigg 1987).")


@dataclass(frozen=True)
class Row:
    """One parameter's numbers: per side and pooled (NaN where not measured), symmetry index (%), the
    normative row and the patient's z-score against it."""

    name: str
    left: float
    right: float
    mean: float
    sd: float
    cv_pct: float
    si_pct: float
    n: int
    norm: NormRow | None = None

    @property
    def z(self) -> float:
        return self.norm.z(self.mean) if self.norm is not None and math.isfinite(self.mean) else math.nan

    @property
    def percentile(self) -> float:
        return percentile(self.z) if math.isfinite(self.z) else math.nan


@dataclass(frozen=True)
class Footprint:
    """A heel contact on the floor: side, position along and across the walking direction (mm)."""

    side: str
    along_mm: float
    across_mm: float


@dataclass(frozen=True)
class ReportConfig:
    """Clinic name on the report header and the normative CSV (None: the shipped one)."""

    clinic_name: str = "Gait laboratory"
    norms_csv: Path | None = None

    @classmethod
    def from_env(cls, env: dict | None = None) -> ReportConfig:
        """``GAITCAP_CLINIC_NAME``, ``GAITCAP_NORMS_CSV``."""
        env = os.environ if env is None else env
        csv = env.get("GAITCAP_NORMS_CSV")
        return cls(clinic_name=env.get("GAITCAP_CLINIC_NAME", cls.clinic_name), norms_csv=Path(csv) if csv else None)


@dataclass(frozen=True)
class ReportContent:
    """Everything on a trial's report."""

    clinic_name: str
    trial: cat.TrialInfo
    patient: pat.PatientInfo
    details: pat.TrialDetailsInfo
    age: int | None
    stage: str
    method: str
    rows: tuple[Row, ...]
    warnings: tuple[str, ...]
    analysis_notes: tuple[str, ...]
    data_quality: dict
    footprints: tuple[Footprint, ...]
    heel_plot_png: bytes | None
    norm_citations: tuple[str, ...]
    version: str
    num_steps: int
    num_passes: int
    previous: PreviousVisit | None = None
    flags: tuple[str, ...] = field(default_factory=tuple)
    data_problems: tuple[str, ...] = field(default_factory=tuple)  # failed consistency rules: not findings
    norm_summary: str = ""  # "6 of 15 parameters have a normal range for age and sex; none outside it."
    consistency: dict = field(default_factory=dict)  # the stage's ConsistencyReport dict
    speed_reference: dict | None = None  # gait speed as % of the age-sex mean (no SD, no z), speed_means
    joint_angles_note: str = ""
    kinematics: dict = field(default_factory=dict)  # kinematics.json with the band for the patient's age
    withheld: tuple[str, ...] = field(default_factory=tuple)  # differences that do not hold: numbers, no finding
    unstable: frozenset[str] = frozenset()  # the parameters of ``withheld``
    validation: dict | None = None  # the lab reference's agreement as shown (services/validation/shown_rows.py)


@dataclass(frozen=True)
class PreviousVisit:
    """The patient's previous visit's trial and its pooled values (parameter -> value)."""

    trial: cat.TrialInfo
    values: dict[str, float]


def _num(x) -> float:
    return float(x) if isinstance(x, (int, float)) and math.isfinite(x) else math.nan


def _stat(groups: dict, side: str, key: str) -> float:
    return _num((groups.get(side) or {}).get(key))


def rows_of(summary: dict, norms: NormTable, *, sex: str, age: int | None) -> tuple[Row, ...]:
    """Report rows from a ``gait.json`` summary (per-side statistics and symmetry), with norms."""
    params, sym = summary.get("parameters", {}), summary.get("asymmetry_pct", {})
    out = []
    for name in PARAMETERS:
        norm = norms.find(name, sex=sex, age=age)
        if name in params:
            g = params[name]
            out.append(Row(name, _stat(g, "left", "mean"), _stat(g, "right", "mean"), _stat(g, "all", "mean"),
                           _stat(g, "all", "sd"), _stat(g, "all", "cv_pct"), _num(sym.get(name)),
                           int((g.get("all") or {}).get("n") or 0), norm))
            continue
        value = _num(summary.get(name))
        if name == "cadence_steps_min":  # per side from that side's mean step time
            st = params.get("step_time_s", {})
            left, right = (60.0 / t if t > 0 else math.nan for t in (_stat(st, "left", "mean"), _stat(st, "right", "mean")))
            mid = 0.5 * (left + right)
            si = 100.0 * abs(left - right) / mid if math.isfinite(mid) and mid else math.nan
            out.append(Row(name, left, right, value, math.nan, math.nan, si, int(summary.get("num_steps") or 0), norm))
        else:
            out.append(Row(name, math.nan, math.nan, value, math.nan, math.nan, math.nan,
                           int(summary.get("num_steps") or 0), norm))
    return tuple(out)


def footprints_of(steps: list[dict]) -> tuple[Footprint, ...]:
    """Heel contacts of the first straight pass, in its walking direction (first contact at 0)."""
    first = [s for s in steps if s.get("pass_index") == 0 and s.get("heel_mm")]
    if len(first) < 2:
        return ()
    a, b = first[0]["heel_mm"], first[-1]["heel_mm"]
    dx, dy = b[0] - a[0], b[1] - a[1]
    norm = math.hypot(dx, dy) or 1.0
    ux, uy = dx / norm, dy / norm
    return tuple(Footprint(s["foot"], (s["heel_mm"][0] - a[0]) * ux + (s["heel_mm"][1] - a[1]) * uy,
                           -(s["heel_mm"][0] - a[0]) * uy + (s["heel_mm"][1] - a[1]) * ux) for s in first)


def findings(rows: tuple[Row, ...], consistency: dict | None = None, *, not_recorded: str = "",
             held: dict | None = None, prefix: str = "") -> Findings:
    """What may be said of the rows: findings against the norms on the numbers that passed the
    consistency rules (``consistency``: a ``ConsistencyReport`` dict; None: none failed), data problems,
    and how many parameters had a normal range (see :mod:`gaitcap.services.reports.findings`);
    ``not_recorded``: what of the patient the norms need is missing (:func:`norms.missing_for_patient`);
    ``held``, ``prefix``: see :func:`~gaitcap.services.reports.findings.findings_of` (:func:`stage_said`)."""
    return findings_of(rows, consistency or {}, PARAMETERS, not_recorded=not_recorded, held=held, prefix=prefix)


#: What a stage's findings begin with (the preliminary stage's say so; the refined stage's need not).
STAGE_PREFIX = {"preliminary": "Preliminary: "}


def stage_said(gait: dict, stage: str, rows: tuple[Row, ...], consistency: dict, *, not_recorded: str = "") -> Findings:
    """What may be said of a stage's rows: :func:`findings` on the numbers that hold over the stage's
    counted steps (``gait.json``'s steps, leave-one-out), the preliminary stage's findings saying so."""
    from gaitcap.reconstruction.gait.stability import leave_one_out

    return findings(rows, consistency, not_recorded=not_recorded, held=leave_one_out(gait.get("steps") or []),
                    prefix=STAGE_PREFIX.get(stage, ""))


def stage_findings(db: cat.Catalog, data_dir: Path, trial_id: str, stage: str | None = None,
                   config: ReportConfig = ReportConfig(), *, norms: NormTable | None = None) -> Findings | None:
    """The findings of one stage of a trial (the best stage by default) as the report makes them; None
    when the stage has no results or no gait file. LookupError for an unknown trial."""
    trial = cat.get_trial(db, trial_id)
    result = cat.get_result(db, trial.id, stage)
    gait = stored_gait(Path(data_dir), trial.id, result.stage) if result is not None else None
    if gait is None:
        return None
    patient = pat.ensure_patient(db, trial.subject_id)
    age = pat.age_at_trial(patient, trial)
    rows = rows_of(gait.get("summary", {}), norms or load_norms(config.norms_csv, units=NORM_UNITS),
                   sex=patient.sex, age=age)
    data_quality = result.report.get("data_quality") or gait.get("data_quality") or {}
    consistency = consistency_of(result.report.get("consistency") or (result.quality or {}).get("consistency")
                                 or gait.get("consistency"), gait, data_quality)
    return stage_said(gait, result.stage, rows, consistency,
                      not_recorded=missing_for_patient(sex=patient.sex, age=age))


def flags_of(rows: tuple[Row, ...], consistency: dict | None = None) -> tuple[str, ...]:
    """Plain-word flags: values outside the normative 95 % band, sides differing by more than 10 %, on
    parameters not in doubt by ``consistency``."""
    return findings(rows, consistency).findings


def sides_of(summary: dict) -> dict[str, dict]:
    """Per parameter of a ``gait.json`` summary: ``left``, ``right``, ``all`` ({n, mean, sd, cv_pct}) and
    ``symmetry_index_pct`` (None where not measured)."""
    sym = summary.get("asymmetry_pct", {})
    return {name: {**{side: groups.get(side) for side in ("left", "right", "all")},
                   "symmetry_index_pct": sym.get(name)} for name, groups in summary.get("parameters", {}).items()}


def stored_gait(data_dir: Path, trial_id: str, stage: str) -> dict | None:
    """The stage's ``gait.json`` as a dict, None when it was not written."""
    try:
        return _gait_json(Path(data_dir), trial_id, stage)
    except FileNotFoundError:
        return None


def _gait_json(data_dir: Path, trial_id: str, stage: str) -> dict:
    path = trial_files(data_dir, trial_id).stage_file(stage, "gait_json")
    if not path.is_file():
        raise FileNotFoundError(f"trial {trial_id}: the {stage} gait analysis file (gait.json) is missing")
    return json.loads(path.read_text(encoding="utf-8"))


def _pooled(result: cat.ResultInfo) -> dict[str, float]:
    s = result.summary
    return {"gait_speed_m_s": _num((s.get("gait_speed_m_per_s") or {}).get("mean")),
            "cadence_steps_min": _num((s.get("cadence_steps_per_min") or {}).get("mean")),
            **{k: _num(v.get("mean")) for k, v in s.items() if k in PARAMETERS}}


def previous_visit(db: cat.Catalog, trial: cat.TrialInfo, data_dir: Path | None = None) -> PreviousVisit | None:
    """The newest trial with results of an earlier session of the same patient (void ones left out)."""
    earlier = [t for t in cat.list_trials(db, subject_id=trial.subject_id, limit=1000)
               if t.created_at < trial.created_at and t.session != trial.session]
    voided = pat.details_of(db, [t.id for t in earlier])
    for t in earlier:
        if t.id in voided and voided[t.id].voided:
            continue
        result = cat.get_result(db, t.id)
        if result is None:
            continue
        gait = stored_gait(data_dir, t.id, result.stage) if data_dir is not None else None
        if gait is None:
            return PreviousVisit(t, _pooled(result))
        empty = NormTable((), (), "")
        return PreviousVisit(t, {r.name: r.mean for r in rows_of(gait.get("summary", {}), empty, sex="", age=None)})
    return None


def stored_kinematics(data_dir: Path, trial_id: str, stage: str) -> dict | None:
    """The stage's ``kinematics.json`` as a dict, None when it was not written."""
    path = trial_files(data_dir, trial_id).stage_file(stage, "kinematics_json")
    return json.loads(path.read_text(encoding="utf-8")) if path.is_file() else None


def joint_angles_note(data: dict | None) -> str:
    """Why a stage's ``kinematics.json`` (``data``, None when not written) has no key joint-angle values,
    or which values were not measured; "" when there is nothing to say."""
    if data is None:
        return "Joint kinematics were not computed for this trial."
    if data.get("available") is False:
        return f"Joint kinematics unavailable: {data.get('reason', 'no reason given')}."
    measured = any(isinstance(stats, dict) and isinstance(stats.get("mean"), (int, float))
                   for values in (data.get("key_values") or {}).values() for stats in values.values())
    held = "; ".join(f"{name.replace('_', ' ')} not measured ({why})"
                     for name, why in (data.get("not_measured") or {}).items())
    if not measured:
        return " ".join(filter(None, ["Joint kinematics have no key values for this trial.", held]))
    return held + "." if held else ""


def _speed_reference(rows: tuple[Row, ...], sex: str, age: int | None) -> dict | None:
    speed = next((r.mean for r in rows if r.name == "gait_speed_m_s"), math.nan)
    found = compare_speed(speed, sex=sex, age=age)
    return found.to_dict() if found is not None else None


def _version() -> str:
    from importlib.metadata import PackageNotFoundError, version

    try:
        return version("gaitcap")
    except PackageNotFoundError:
        return "unknown"


def report_content(db: cat.Catalog, data_dir: Path, trial_id: str, config: ReportConfig = ReportConfig(),
                   *, norms: NormTable | None = None) -> ReportContent:
    """Gather a trial's report. LookupError (TrialNotFound) for an unknown trial, FileNotFoundError when
    the trial has no results or its gait file is missing."""
    from gaitcap.services.kinematics.shown import with_norms

    trial = cat.get_trial(db, trial_id)
    result = cat.get_result(db, trial.id)
    if result is None:
        raise FileNotFoundError(f"trial {trial.id} has no results yet")
    gait = _gait_json(Path(data_dir), trial.id, result.stage)
    patient = pat.ensure_patient(db, trial.subject_id)
    age = pat.age_at_trial(patient, trial)
    norms = norms or load_norms(config.norms_csv, units=NORM_UNITS)
    rows = rows_of(gait.get("summary", {}), norms, sex=patient.sex, age=age)
    data_quality = result.report.get("data_quality") or gait.get("data_quality") or {}
    consistency = consistency_of(result.report.get("consistency") or (result.quality or {}).get("consistency")
                                 or gait.get("consistency"), gait, data_quality)
    said = stage_said(gait, result.stage, rows, consistency, not_recorded=missing_for_patient(sex=patient.sex, age=age))
    kinematics = stored_kinematics(Path(data_dir), trial.id, result.stage)
    shown_kinematics = with_norms(kinematics, age) if kinematics is not None else {}
    angles = key_value_findings(shown_kinematics)
    png = trial_files(data_dir, trial.id).stage_file(result.stage, "report_png")
    validation = stored_validation(trial_files(data_dir, trial.id).root)
    return ReportContent(
        clinic_name=config.clinic_name, trial=trial, patient=patient, details=pat.get_details(db, trial.id),
        age=age, stage=result.stage, method=result.method, rows=rows,
        warnings=tuple(cat.warnings_of(cat.get_quality(db, trial.id))),
        analysis_notes=tuple(gait.get("warnings") or ()), data_quality=data_quality,
        footprints=footprints_of(gait.get("steps") or []), heel_plot_png=png.read_bytes() if png.is_file() else None,
        norm_citations=norms.citations, version=_version(),
        num_steps=int(gait.get("summary", {}).get("num_steps") or 0),
        num_passes=int(gait.get("summary", {}).get("num_passes") or 0),
        previous=previous_visit(db, trial, Path(data_dir)), flags=said.findings + angles.findings,
        withheld=said.withheld + angles.withheld, unstable=said.unstable,
        data_problems=tuple(filter(None, (outage_problem(data_quality),))) + said.data_problems, norm_summary=" ".join(filter(None, (said.norm_summary, angles.summary))),
        consistency=consistency, speed_reference=_speed_reference(rows, patient.sex, age),
        joint_angles_note=joint_angles_note(kinematics),
        kinematics=shown_kinematics, validation=shown_validation(validation) if validation else None)
