"""Where deploy/bootstrap.sh installs the OpenSim model, marker sets, scaling/IK setups and the norms."""

from __future__ import annotations

import json
from functools import lru_cache
from pathlib import Path

from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.kinematics.angles import VARIABLES
from gaitcap.reconstruction.kinematics.norms import (
    NormBand,
    NormSet,
    bands_from_curves,
    bands_from_schwartz,
    choose_norms,
)

MODEL_FILE = "Model_Pose2Sim_simple.osim"


def setup_dir() -> Path:
    """``$GAITCAP_OPENSIM_DIR`` or ``<venv>/share/gaitcap/opensim``."""
    return share_path("opensim", env="GAITCAP_OPENSIM_DIR")


def norms_file() -> Path:
    """``$GAITCAP_NORMS_FILE`` or ``<venv>/share/gaitcap/normative/Schwartz2008.json``."""
    return share_path("normative", "Schwartz2008.json", env="GAITCAP_NORMS_FILE")


def adult_norms_file() -> Path:
    """``$GAITCAP_ADULT_NORMS_FILE`` or ``<venv>/share/gaitcap/normative/BioCV2024_adult.json``."""
    return share_path("normative", "BioCV2024_adult.json", env="GAITCAP_ADULT_NORMS_FILE")


def setup_files(setup: str) -> dict[str, Path]:
    """model, markers, scaling and ik files of a marker layout (FileNotFoundError naming the missing ones)."""
    d = setup_dir()
    marker_name = "BlazePose" if setup == "Blazepose" else setup
    files = {"model": d / MODEL_FILE, "markers": d / f"Markers_{marker_name}.xml",
             "scaling": d / f"Scaling_Setup_Pose2Sim_{setup}.xml", "ik": d / f"IK_Setup_Pose2Sim_{setup}.xml"}
    missing = [str(p) for p in files.values() if not p.is_file()]
    if missing:
        raise FileNotFoundError(f"OpenSim setup files missing (run deploy/bootstrap.sh): {', '.join(missing)}")
    return files


@lru_cache(maxsize=1)
def norm_bands() -> dict[str, NormBand]:
    """The normal-gait bands, {} when the norms file is not installed."""
    path = norms_file()
    if not path.is_file():
        return {}
    return bands_from_schwartz(json.loads(path.read_text()))


@lru_cache(maxsize=1)
def _adult() -> tuple[dict[str, NormBand], str]:
    path = adult_norms_file()
    if not path.is_file():
        return {}, ""
    data = json.loads(path.read_text())
    return bands_from_curves(data), str(data.get("source", path.name))


def norms_for_age(age_years: int | None) -> NormSet:
    """The normal-gait bands for a patient of that age (years; None when not recorded), see
    :func:`gaitcap.reconstruction.kinematics.norms.choose_norms`."""
    adults, source = _adult()
    return choose_norms(age_years, children=norm_bands(), adults=adults, adult_source=source,
                        variables=tuple(VARIABLES))
