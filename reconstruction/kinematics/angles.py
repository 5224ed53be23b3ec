"""Clinical joint-angle variables and how each one is read from the OpenSim model's coordinates.

Conventions (degrees, per side): flexion, adduction, internal rotation and dorsiflexion positive; pelvis
anterior tilt positive, obliquity positive when this side's hip is up, rotation positive when this side is
forward; trunk flexion relative to the pelvis positive. The signs of the model's coordinates were read off
the model (moving one coordinate and watching its markers); tests/services/test_kinematics.py checks them.
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


PELVIS = ("pelvis_tilt", "pelvis_list", "pelvis_rotation")
TRAVEL = ("pelvis_tx", "pelvis_tz")  # the pelvis's position on the floor (m; the model's y is up)
PROGRESSION_WINDOW_S = 1.1  # about one stride: the pelvis's mean travel (or heading) over it is the progression
MIN_TRAVEL_M_S = 0.3  # slower than this over the window (standing, turning on the spot): the pelvis's own heading


def _rz(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, -s, z], -1), np.stack([s, c, z], -1), np.stack([z, z, o], -1)], -2)


def _rx(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([o, z, z], -1), np.stack([z, c, -s], -1), np.stack([z, s, c], -1)], -2)


def _ry(a):
    c, s, z, o = np.cos(a), np.sin(a), np.zeros_like(a), np.ones_like(a)
    return np.stack([np.stack([c, z, s], -1), np.stack([z, o, z], -1), np.stack([-s, z, c], -1)], -2)


def _moving_mean(x: np.ndarray, n: int) -> np.ndarray:
    ok = np.isfinite(x)
    k = np.ones(max(1, n))
    num = np.convolve(np.where(ok, x, 0.0), k, mode="same")
    den = np.convolve(ok.astype(float), k, mode="same")
    return np.where(den > 0, num / np.maximum(den, 1), np.nan)


def pelvis_in_progression(coordinates_deg: dict[str, np.ndarray], times_s: np.ndarray, *,
                          window_s: float = PROGRESSION_WINDOW_S) -> dict[str, np.ndarray]:
    """The pelvis angles relative to the direction of progression instead of the room.

    The model's ground-pelvis joint is R = Rz(tilt) Rx(list) Ry(rotation) in the room (y up), so its tilt
    and list are about the room's axes: walking along the room's diagonal, or back, mixes and flips them.
    The progression heading is the direction the pelvis travels, its velocity on the floor averaged over
    ``window_s`` (about a stride; ``pelvis_tx``, ``pelvis_tz`` in m), as a laboratory's progression axis is;
    where it travels slower than ``MIN_TRAVEL_M_S`` or its position is not given, the pelvis's own heading
    averaged over the window (which keeps part of the stride's swing in it when the stride is not the
    window: on Plug-in-Gait's own curves RMSE 1.6 deg of rotation, docs/validation.md). The pelvis
    orientation is turned back by it and decomposed again in the same order. Returns a copy of
    ``coordinates_deg`` with the three pelvis angles replaced (degrees)."""
    if not all(k in coordinates_deg for k in PELVIS):
        return dict(coordinates_deg)
    rot = np.radians(np.asarray(coordinates_deg["pelvis_rotation"], dtype=np.float64))
    t = np.asarray(times_s, dtype=np.float64)
    dt = float(np.median(np.diff(t))) if t.size > 1 else 1.0
    n = int(round(window_s / dt)) | 1
    ok = np.isfinite(rot)
    unwrapped = np.full_like(rot, np.nan)
    unwrapped[ok] = np.unwrap(rot[ok])
    heading = _moving_mean(unwrapped, n)
    travel = _travel_heading(coordinates_deg, t, n)
    return turned_pelvis(coordinates_deg, heading if travel is None else np.where(np.isfinite(travel), travel, heading))


def _travel_heading(coordinates: dict[str, np.ndarray], t: np.ndarray, n: int) -> np.ndarray | None:
    """(T,) direction (rad, as the pelvis's rotation about the vertical: +x is 0) of the pelvis's floor
    velocity averaged over ``n`` frames; NaN where slower than ``MIN_TRAVEL_M_S``; None without positions."""
    if not all(k in coordinates for k in TRAVEL) or t.size < 3:
        return None
    vx, vz = (_moving_mean(np.gradient(np.asarray(coordinates[k], dtype=np.float64), t), n) for k in TRAVEL)
    return np.where(np.hypot(vx, vz) >= MIN_TRAVEL_M_S, np.arctan2(-vz, vx), np.nan)


def turned_pelvis(coordinates_deg: dict[str, np.ndarray], heading_rad) -> dict[str, np.ndarray]:
    """The pelvis angles in a frame turned by ``heading_rad`` (scalar or (T,), about the room's vertical,
    OpenSim's y): the orientation Rz(tilt) Rx(list) Ry(rotation) turned back by Ry(-heading) and decomposed
    again in the same order; NaN where an angle or the heading is. Returns a copy of ``coordinates_deg``
    with the three pelvis angles replaced (degrees)."""
    if not all(k in coordinates_deg for k in PELVIS):
        return dict(coordinates_deg)
    tilt, lst, rot = (np.radians(np.asarray(coordinates_deg[k], dtype=np.float64)) for k in PELVIS)
    heading = np.broadcast_to(np.asarray(heading_rad, dtype=np.float64), rot.shape)
    ok = np.isfinite(rot)
    fill = lambda a: np.where(np.isfinite(a), a, 0.0)  # noqa: E731
    rel = _ry(-fill(heading)) @ _rz(fill(tilt)) @ _rx(fill(lst)) @ _ry(fill(rot))
    new_list = np.arcsin(np.clip(rel[:, 2, 1], -1.0, 1.0))
    new_rot = np.arctan2(-rel[:, 2, 0], rel[:, 2, 2])
    new_tilt = np.arctan2(-rel[:, 0, 1], rel[:, 1, 1])
    bad = ~(np.isfinite(tilt) & np.isfinite(lst) & ok & np.isfinite(heading))
    out = dict(coordinates_deg)
    for name, v in zip(PELVIS, (new_tilt, new_list, new_rot), strict=True):
        out[name] = np.where(bad, np.nan, np.degrees(v))
    return out


def clinical_angles(coordinates_deg: dict[str, np.ndarray], times_s: np.ndarray | None = None
                    ) -> dict[str, dict[str, np.ndarray]]:
    """variable -> side -> (T,) degrees, for every variable of :data:`VARIABLES`; with ``times_s`` the
    pelvis angles are taken relative to the direction of progression (:func:`pelvis_in_progression`)."""
    coords = coordinates_deg if times_s is None else pelvis_in_progression(coordinates_deg, times_s)
    return {name: {s: v.of(coords, s) for s in SIDES} for name, v in VARIABLES.items()}
