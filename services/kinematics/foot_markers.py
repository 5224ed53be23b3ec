"""The model's foot markers placed in the patient's foot shape (``reconstruction.kinematics.foot``).

On the scaled model in its zero pose, the keypoints' foot template goes on the ankle joint centre (the
talus's origin) with the foot line at right angles to the shank (knee joint centre to ankle joint centre)
and facing the model's forward (its x axis); the heel and toe markers move there, on the calcaneus: the
keypoints' foot is one rigid segment (heel and toes of a detector, or a marker protocol's heel and
forefoot), so the toes' joint (mtp) carries no marker and is held at 0 by the fit (``opensim_engine.PRIORS``).
"""

from __future__ import annotations

import logging

import numpy as np
from gaitcap.reconstruction.kinematics.foot import (
    FOOT_PARTS,
    foot_template,
    foot_torsion_deg,
    template_on_model,
)
from gaitcap.reconstruction.kinematics.frames import room_to_opensim

log = logging.getLogger(__name__)
SIDES = {"L": "l", "R": "r"}
FOOT_BODY = "calcn_{}"
KNEE_JOINT = "walker_knee_{}"


def _location(model, state, body: str) -> np.ndarray:
    return model.getBodySet().get(body).getPositionInGround(state).to_numpy()


def _knee_centre(model, state, side: str) -> np.ndarray:
    """The knee joint's centre (its frame on the femur: the knee marker, ``model_setup``), else the tibia's
    origin (10 mm above it in Pose2Sim's model)."""
    joints = model.getJointSet()
    name = KNEE_JOINT.format(side)
    if joints.contains(name):
        return joints.get(name).getParentFrame().getPositionInGround(state).to_numpy()
    return _location(model, state, f"tibia_{side}")


def place_foot_markers(osim, model, points_mm: np.ndarray, names: tuple[str, ...]) -> dict[str, list[float]]:
    """Move the heel and toe markers of ``model`` (scaled; changed in place) onto its calcanei in the shape
    of the keypoints (``points_mm`` (T, M, 3) mm, room frame; ``names`` the model's marker names). A side
    whose ankle, heel or big toe the keypoints lack, or that has too few frames, keeps the model's markers
    (logged). Returns marker -> its new location (m, calcaneus frame)."""
    state = model.initSystem()
    for i in range(model.getCoordinateSet().getSize()):
        c = model.getCoordinateSet().get(i)
        if c.getMotionType() == 1:  # rotational: the zero pose
            c.setValue(state, 0.0, False)
    model.realizePosition(state)
    markers = model.getMarkerSet()
    ground = model.getGround()
    col = {n: i for i, n in enumerate(names)}
    placed: dict[str, list[float]] = {}
    torsions: dict[str, float] = {}
    for letter, s in SIDES.items():
        parts = {p: room_to_opensim(points_mm[:, col[letter + p]]) / 1000.0 for p in FOOT_PARTS if letter + p in col}
        try:
            template = foot_template(parts)
        except ValueError as exc:
            log.info("foot markers of side %s left where the model has them: %s", letter, exc)
            continue
        leg = {p: room_to_opensim(points_mm[:, col[letter + p]]) / 1000.0 for p in ("Hip", "Knee")
               if letter + p in col}
        torsion = foot_torsion_deg(leg["Hip"], leg["Knee"], parts["Ankle"], parts["Heel"], parts["BigToe"]) \
            if len(leg) == 2 else float("nan")
        if not np.isfinite(torsion):
            log.info("foot of side %s: no frame with the knee bent shows its torsion; the foot faces forward", letter)
            torsion = 0.0
        body = model.getBodySet().get(FOOT_BODY.format(s))
        where = template_on_model(template, ankle_centre=_location(model, state, f"talus_{s}"),
                                  knee_centre=_knee_centre(model, state, s), forward=np.array([1.0, 0, 0]),
                                  torsion_deg=torsion)
        torsions[letter] = round(torsion, 1)
        for part, p in where.items():
            name = letter + part
            if part == "Ankle" or not markers.contains(name):
                continue
            marker = markers.get(name)
            local = ground.findStationLocationInAnotherFrame(state, osim.Vec3(*p), body).to_numpy()
            marker.connectSocket_parent_frame(body)
            marker.set_location(osim.Vec3(*local))
            placed[name] = [round(float(v), 4) for v in local]
    model.finalizeConnections()
    log.info("foot torsion from the knee's plane (deg, + to the left): %s", torsions)
    return placed
