"""The patient's foot as the keypoints show it: a rigid template of the ankle, heel and toes, and where its
points go on a model whose foot is at right angles to its shank.

A model's foot markers sit where its makers put them; the keypoints' heel and toes sit where the detector
(or a marker protocol) puts them, higher or lower, further forward or back. Fitted together, every
difference in shape turns the model's foot (the ankle, subtalar and toe joints share out what no pose
explains: on real Plug-in-Gait walks the subtalar joint rested on its -20 deg bound and the ankle lost
half of push-off, docs/kinematics.md). The keypoints of one foot are (nearly) rigid: their shape, the
median over the trial in the foot's own frame, is the template; placed on the model in its zero pose with
the foot line (heel to big toe) at right angles to the shank and the ankle keypoint on the ankle joint
centre, the model's zero is the joint-centre zero of :mod:`.geometric` and its foot has the patient's
shape.

Frames: the foot frame has x along heel -> big toe, y up towards the ankle (the ankle keypoint in the x-y
plane), z = x cross y (to the right in a right-handed room); points in mm.
"""

from __future__ import annotations

import numpy as np

# the foot's points, as the model's marker names end (``L`` / ``R`` + the part); Ankle anchors the template
FOOT_PARTS = ("Ankle", "Heel", "BigToe", "SmallToe")
MIN_FRAMES = 10
MIN_BEND_DEG = 20.0


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def foot_frames(ankle: np.ndarray, heel: np.ndarray, big_toe: np.ndarray) -> np.ndarray:
    """(T, 3, 3) rows x, y, z of each frame's foot frame (see the module docstring); NaN where a point is."""
    x = _unit(big_toe - heel)
    up = ankle - heel
    y = _unit(up - np.sum(up * x, axis=-1, keepdims=True) * x)
    return np.stack([x, y, np.cross(x, y)], axis=-2)


def foot_template(points_mm: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """part -> (3,) mm in the foot frame (origin at the heel), the median over the frames where the ankle,
    heel and big toe are (and the small toe, for its own point). ``points_mm``: part -> (T, 3) room frame.
    ValueError when fewer than ``MIN_FRAMES`` frames have the ankle, heel and big toe."""
    for part in FOOT_PARTS[:3]:
        if part not in points_mm:
            raise ValueError(f"foot template: no {part} keypoint")
    ankle, heel, toe = (np.asarray(points_mm[p], dtype=np.float64) for p in FOOT_PARTS[:3])
    ok = np.isfinite(ankle).all(-1) & np.isfinite(heel).all(-1) & np.isfinite(toe).all(-1)
    if ok.sum() < MIN_FRAMES:
        raise ValueError(f"foot template: {int(ok.sum())} frames have the ankle, heel and big toe "
                         f"(at least {MIN_FRAMES} needed)")
    axes = foot_frames(ankle[ok], heel[ok], toe[ok])
    out = {}
    for part in FOOT_PARTS:
        p = points_mm.get(part)
        if p is None:
            continue
        local = np.einsum("tij,tj->ti", axes, np.asarray(p, dtype=np.float64)[ok] - heel[ok])
        local = local[np.isfinite(local).all(-1)]
        if len(local) >= MIN_FRAMES:
            out[part] = np.median(local, axis=0)
    return out


def foot_torsion_deg(hip: np.ndarray, knee: np.ndarray, ankle: np.ndarray, heel: np.ndarray,
                     big_toe: np.ndarray) -> float:
    """The foot line's turn about the shank from the knee's hinge (degrees, + towards the body's left),
    the median over frames with the knee bent more than :data:`MIN_BEND_DEG` (the hip, knee and ankle then
    span the plane the knee bends in; the shank's forward is the normal of that plane's hinge axis). People's
    feet point outwards of the knee's plane (tibial torsion: the right foot negative, the left positive):
    a model whose foot faces straight ahead must turn its subtalar joint to follow. NaN without such frames.
    All (T, 3) in one right-handed frame."""
    thigh, shank = knee - hip, ankle - knee
    up = _unit(-shank)
    hinge = np.cross(thigh, shank)  # towards the body's left on both legs while the knee bends forward
    bend = np.degrees(np.arctan2(np.linalg.norm(hinge, axis=-1), np.sum(thigh * shank, axis=-1)))
    left = _unit(hinge)
    forward = np.cross(left, up)
    foot = big_toe - heel
    angle = np.degrees(np.arctan2(np.sum(foot * left, axis=-1), np.sum(foot * forward, axis=-1)))
    ok = np.isfinite(angle) & (bend > MIN_BEND_DEG) & (np.sum(np.cross(thigh, shank) * left, axis=-1) > 0)
    return float(np.median(angle[ok])) if ok.sum() >= MIN_FRAMES else float("nan")


def template_on_model(template: dict[str, np.ndarray], *, ankle_centre: np.ndarray, knee_centre: np.ndarray,
                      forward: np.ndarray, torsion_deg: float = 0.0) -> dict[str, np.ndarray]:
    """part -> (3,) where the template's points go on a model in its zero pose (the model's frame and
    units): the template's ankle on ``ankle_centre``, its foot line at right angles to the shank (knee ->
    ankle centre), turned ``torsion_deg`` from ``forward`` about the shank towards the left
    (:func:`foot_torsion_deg`), its y axis up along the shank. The vectors must be in one right-handed
    frame whose units match the template's; the model's knee bends about the axis normal to ``forward``
    and the shank."""
    down = _unit(np.asarray(ankle_centre, float) - np.asarray(knee_centre, float))
    fwd = np.asarray(forward, dtype=np.float64)
    fwd = _unit(fwd - np.dot(fwd, down) * down)
    y = -down
    left = np.cross(y, fwd)
    turn = np.radians(torsion_deg)
    x = np.cos(turn) * fwd + np.sin(turn) * left
    axes = np.stack([x, y, np.cross(x, y)])  # rows: the foot frame's axes in the model's frame
    origin = np.asarray(ankle_centre, float) - template["Ankle"] @ axes
    return {part: origin + p @ axes for part, p in template.items()}
