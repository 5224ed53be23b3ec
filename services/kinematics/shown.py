"""A stage's kinematics as the page, the REST API and the report show them: the stored
``kinematics.json`` with the normal-gait band chosen by the patient's age at the trial (the band can change
after the fit, when the patient's birth year is recorded, so it is chosen when the kinematics are read), and
``norms.not_drawn``: the bands the charts leave out because the table does not compare with them."""

from __future__ import annotations

from gaitcap.reconstruction.kinematics.report import curves_csv
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import patients as pat
from gaitcap.services.kinematics.files import norms_for_age


def patient_age(db: cat.Catalog, trial_id: str) -> int | None:
    """The patient's age in years at the trial, None when the birth year is not recorded."""
    trial = cat.get_trial(db, trial_id)
    try:
        patient = pat.get_patient(db, trial.subject_id)
    except pat.PatientNotFound:
        return None
    return pat.age_at_trial(patient, trial)


def with_norms(data: dict, age_years: int | None) -> dict:
    """``kinematics.json`` content with ``norms`` replaced by the set for that age (unchanged when the
    kinematics are unavailable)."""
    if data.get("available") is False:
        return data
    return {**data, "norms": norms_for_age(age_years).to_dict()}




def curves_png(k: dict) -> bytes:
    """The figure of the curves per side over the band, titled with whose band it is."""
    from gaitcap.services.kinematics.plot import figure_title, side_curves_png

    return side_curves_png(k, title=figure_title(k))


# format -> how it is made from the JSON form (with the band chosen for the patient)
SHOWN_FORMATS = {"csv": curves_csv, "png": curves_png}
