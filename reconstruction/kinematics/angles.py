"""Clinical joint-angle variables and how each one is read from the OpenSim model's coordinates.

Conventions (degrees, per side): flexion, adduction, internal rotation and dorsiflexion positive; pelvis
anterior tilt positive, obliquity positive when this side's hip is up, rotation positive when this side is
forward; trunk flexion relative to the pelvis positive. The signs of the model's coordinates were read off
the model (moving one coordinate and watching its markers), see tests/reconstruction/kinematics.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SIDES = ("left", "right")


@dataclass(frozen=True)
class AngleVariable:
    """One curve per side: ``sign[side] * coordinate[side]`` of the model's coordinates (degrees)."""

    name: str
    label: str
    coordinate: dict[str, str]
    sign: dict[str, float]

    def of(self, coordinates_deg: dict[str, np.ndarray], side: str) -> np.ndarray:
        """(T,) degrees of this variable on ``side`` from the model's coordinates (KeyError naming one)."""
        coord = self.coordinate[side]
        if coord not in coordinates_deg:
            raise KeyError(f"model coordinates have no {coord!r} (needed for {self.name})")
        return self.sign[side] * np.asarray(coordinates_deg[coord], dtype=np.float64)


def _same(coord: str, sign: float = 1.0) -> tuple[dict[str, str], dict[str, float]]:
    return {s: coord for s in SIDES}, {s: sign for s in SIDES}


def _sided(stem: str) -> tuple[dict[str, str], dict[str, float]]:
    return {"left": f"{stem}_l", "right": f"{stem}_r"}, {s: 1.0 for s in SIDES}


VARIABLES: dict[str, AngleVariable] = {v.name: v for v in (
    AngleVariable("pelvis_tilt", "Pelvic tilt (anterior +)", *_same("pelvis_tilt", -1.0)),
    AngleVariable("pelvis_obliquity", "Pelvic obliquity (up +)", {s: "pelvis_list" for s in SIDES},
                  {"left": 1.0, "right": -1.0}),
    AngleVariable("pelvis_rotation", "Pelvic rotation (forward +)", {s: "pelvis_rotation" for s in SIDES},
                  {"left": -1.0, "right": 1.0}),
    AngleVariable("hip_flexion", "Hip flexion / extension", *_sided("hip_flexion")),
    AngleVariable("hip_adduction", "Hip adduction / abduction", *_sided("hip_adduction")),
    AngleVariable("hip_rotation", "Hip rotation (internal +)", *_sided("hip_rotation")),
    AngleVariable("knee_flexion", "Knee flexion / extension", *_sided("knee_angle")),
    AngleVariable("ankle_dorsiflexion", "Ankle dorsi / plantarflexion", *_sided("ankle_angle")),
    AngleVariable("trunk_flexion", "Trunk flexion relative to the pelvis", *_same("L5_S1_Flex_Ext", -1.0)),
)}


def clinical_angles(coordinates_deg: dict[str, np.ndarray]) -> dict[str, dict[str, np.ndarray]]:
    """variable -> side -> (T,) degrees, for every variable of :data:`VARIABLES`."""
    return {name: {s: v.of(coordinates_deg, s) for s in SIDES} for name, v in VARIABLES.items()}
