"""The worker's kinematics step: joint angles of a processed stage, computed after its results are stored
(the page shows the gait result first; the angles follow).

It never fails the trial: when the engine is missing or the model cannot be fitted, the stage's
``kinematics/kinematics.json`` says why (``{"available": false, "reason": ...}``), which the API returns.
"""

from __future__ import annotations

import json
import logging

from gaitcap.reconstruction.result import Reconstruction
from gaitcap.services.processing.apart import call_apart
from gaitcap.services.processing.artifacts import TrialFiles

log = logging.getLogger(__name__)


def _steps(files: TrialFiles, stage: str) -> list[dict]:
    path = files.stage_file(stage, "gait_json")
    return json.loads(path.read_text()).get("steps", []) if path.is_file() else []


def _fit_files(*args, **kwargs) -> None:
    """``trial_kinematics`` for its files only: the report stays in the child (nothing to send back)."""
    from gaitcap.services.kinematics.trial import trial_kinematics

    trial_kinematics(*args, **kwargs)


def kinematics_step(files: TrialFiles, stage: str, traj: Reconstruction, *, age_years: int | None = None) -> bool:
    """Fit, report and export the stage's joint kinematics; True when they were computed. ``age_years``:
    the patient's age at the trial (None when not recorded) picks the normal-gait band of the files."""
    from gaitcap.services.kinematics import KinematicsUnavailable
    from gaitcap.services.kinematics.trial import write_unavailable

    out = files.stage_file(stage, "kinematics_json").parent
    try:  # in a child process: OpenSim keeps native memory for every frame it fits (``apart``)
        call_apart(_fit_files, traj.points_mm, traj.times_s, traj.joint_names, steps=_steps(files, stage),
                   quality=traj.quality, out_dir=out, age_years=age_years, what=f"{files.root.name} {stage} kinematics")
    except KinematicsUnavailable as exc:
        log.warning("%s %s: kinematics are unavailable: %s", files.root.name, stage, exc)
        return False
    except Exception as exc:  # noqa: BLE001 - a failed model fit must not fail the trial; the reason is kept
        log.exception("%s %s: kinematics failed", files.root.name, stage)
        write_unavailable(out, f"the model fit failed: {type(exc).__name__}: {exc}")
        return False
    return True
