"""The kinematics engine interface: what an engine is asked (:class:`FitRequest`) and what it returns
(:class:`ModelFit`). An engine scales its model to the markers and solves inverse kinematics."""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

import numpy as np


class KinematicsUnavailable(RuntimeError):
    """The engine cannot run here (package or setup files missing); the message says what to install."""


@dataclass(frozen=True, eq=False)
class ModelFit:
    """times_s (T,); coordinates_deg: model coordinate -> (T,) (rotations degrees, translations m; NaN in
    frames that could not be fitted); marker_errors_mm: marker -> {"rms", "max"} over the fitted frames;
    files: "osim" (scaled model), "mot" (coordinates), "trc" (the markers fitted) -> path;
    scale_factors: body -> factor; seconds: {"scale", "ik"}; held: coordinate -> why it was held by the
    fit rather than measured from the markers (its values are the fit's prior, not the patient's);
    zero_offsets_deg: clinical variable -> side -> degrees the fitted model's markers read in its zero pose,
    measured like the keypoints (``geometric.model_zero_offsets``; add it to the model's angle for the
    joint-centre definitions of the norm sources); bounds: the coordinates that rested on a bound of their
    range (``reconstruction.kinematics.bounds.BoundHit``), each a warning."""

    times_s: np.ndarray
    coordinates_deg: dict[str, np.ndarray]
    marker_errors_mm: dict[str, dict[str, float]]
    files: dict[str, Path]
    scale_factors: dict[str, float] = field(default_factory=dict)
    seconds: dict[str, float] = field(default_factory=dict)
    held: dict[str, str] = field(default_factory=dict)
    zero_offsets_deg: dict[str, dict[str, float]] = field(default_factory=dict)
    bounds: tuple = ()


@dataclass(frozen=True)
class FitRequest:
    """What to fit: markers (T, M, 3) mm in the room frame (z up), NaN = missing; marker_names (M,);
    weights (M,) relative confidence in [0, 1]; setup: marker layout name; out_dir: where the files go;
    stem: their base name; mass_kg: the patient's mass (sets inertia only, not angles)."""

    points_mm: np.ndarray
    times_s: np.ndarray
    marker_names: tuple[str, ...]
    weights: np.ndarray
    setup: str
    out_dir: Path
    stem: str = "trial"
    mass_kg: float = 70.0


class KinematicsEngine(Protocol):
    name: str

    def fit(self, request: FitRequest) -> ModelFit: ...
