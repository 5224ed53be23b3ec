"""The model as the keypoints see it: the marker set with the hip, knee and ankle markers on their joint
centres, and the pelvis scaled in width by the hips' distance and otherwise by the patient's overall size."""

from __future__ import annotations

from pathlib import Path

import numpy as np

# marker -> the joints whose centre (mean) it is, on the joints' parent body. The keypoint layouts' hips
# are hip joint centres (the synthetic walker's thighs turn about them; a detector's hip estimates the
# joint), not the skin points below and beside them where the Pose2Sim marker sets put them (15 mm lower,
# 7 mm forward, 20 mm lateral): there, tilting the pelvis moved the hip markers against the thighs and the fit used the pelvis's
# tilt to absorb the difference. The ankle keypoint is the ankle joint centre too (between the malleoli; the
# foot's markers are placed around it in the keypoints' foot shape, ``foot_markers``). So is the knee
# keypoint (a detector's knee, Plug-in-Gait's knee joint centre, the walker's hinge): Pose2Sim's knee marker
# sits on the femur 10 mm above the knee's axis (and 3 mm in front of it), so the model's shank (the tibia,
# turning about that axis) was not the keypoints' knee -> ankle line once the knee bent, and the rigid
# thigh and shank fitted to the markers read the knee's and the ankle's angles off by as much (real walks'
# joint centres: knee RMSE 1.05 / 1.73 -> 0.77 / 1.34 deg on PiG_Motion-FlatFoot-Full, ankle r 0.979 /
# 0.971 -> 0.982 / 0.976; the synthetic walker's exact keypoints: knee 0.49 -> 0.29 deg; docs/kinematics.md).
JOINT_CENTRE_MARKERS = {"LHip": ("hip_l",), "RHip": ("hip_r",), "Hip": ("hip_l", "hip_r"), "CHip": ("hip_l", "hip_r"),
                        "LKnee": ("walker_knee_l",), "RKnee": ("walker_knee_r",),
                        "LAnkle": ("ankle_l",), "RAnkle": ("ankle_r",)}


def markers_at_joint_centres(osim, model) -> None:
    """Move the markers of :data:`JOINT_CENTRE_MARKERS` onto their joints' centres (the joints' parent
    frames, on the body the marker is on); a marker on another body is left alone."""
    markers, joints = model.getMarkerSet(), model.getJointSet()
    for name, names in JOINT_CENTRE_MARKERS.items():
        if not markers.contains(name) or not all(joints.contains(j) for j in names):
            continue
        marker = markers.get(name)
        body = marker.getSocket("parent_frame").getConnecteePath().rstrip("/").split("/")[-1]
        frames = [osim.PhysicalOffsetFrame.safeDownCast(joints.get(j).getParentFrame()) for j in names]
        if any(f.getSocket("parent").getConnecteePath().rstrip("/").split("/")[-1] != body for f in frames):
            continue
        marker.set_location(osim.Vec3(*np.mean([f.get_translation().to_numpy() for f in frames], axis=0)))


# The model's knees (Rajagopal's "walker knee") turn the tibia inwards as they bend (15 deg at 90 deg of
# flexion), tilt it (2 deg) and slide it (7 mm): the keypoints' knee is a hinge (hip, knee and ankle joint
# centres, a rigid shank). With the coupling, a swinging foot pointed away from where the keypoints put it
# and the fit shared the difference out over the hip, knee and ankle (knee markers 20-26 mm off in swing on
# real walks, docs/kinematics.md). Every transform axis of these joints but the flexion is held at its
# value in the straight knee.
HINGED_KNEES = ("walker_knee_l", "walker_knee_r")
FLEXION_AXIS = "rotation1"


def hinged_knees(osim, model) -> None:
    """Make the knees of :data:`HINGED_KNEES` hinges: their coupled axes constant at the straight knee."""
    joints = model.getJointSet()
    for name in HINGED_KNEES:
        if not joints.contains(name):
            continue
        transform = osim.CustomJoint.safeDownCast(joints.get(name)).getSpatialTransform()
        for i in range(6):
            axis = transform.updTransformAxis(i)
            if axis.getName() != FLEXION_AXIS and axis.hasFunction():
                axis.set_function(osim.Constant(axis.getFunction().calcValue(osim.Vector(1, 0.0))))


def model_with_markers(osim, files: dict[str, Path]):
    """The layout's model with its marker set, hip, knee and ankle markers at their joint centres, the
    knees hinges."""
    model = osim.Model(str(files["model"]))
    model.set_MarkerSet(osim.MarkerSet(str(files["markers"])))
    markers_at_joint_centres(osim, model)
    hinged_knees(osim, model)
    return model


PELVIS_BODIES = ("pelvis", "sacrum")


def pelvis_width_only(factors: dict[str, tuple[float, float, float]]) -> dict[str, tuple[float, float, float]]:
    """The hips' distance measures the pelvis's width (its Z axis) only: its depth and height (X, Y) take
    the median factor of the other bodies (the patient's overall size). Scaling all three by the hips'
    distance moves the lumbar joint, the trunk and the hip joints as far as the hips are wider than the
    model's, a wide-hipped patient's trunk ends too high."""
    others = [f[0] for b, f in factors.items() if b not in PELVIS_BODIES]
    if not others:
        return factors
    size = float(np.median(others))
    return {b: (size, size, f[2]) if b in PELVIS_BODIES else f for b, f in factors.items()}
