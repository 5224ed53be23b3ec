"""A camera moved after calibration: the fault the rig check must find (tests, benchmarks)."""

from __future__ import annotations

import numpy as np
from gaitcap.reconstruction.calibration.geometry import rvec_of
from gaitcap.reconstruction.camera import Rig, rodrigues_to_matrix
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.triangulation import robust_triangulate


def with_camera_moved(rig: Rig, name: str, *, rotation_deg: float, shift_mm: float = 0.0,
                      axis=(0.0, 1.0, 0.0), direction=(1.0, 0.0, 0.0)) -> Rig:
    """``rig`` with camera ``name`` turned by ``rotation_deg`` about ``axis`` (world frame, through its
    centre) and its centre moved by ``shift_mm`` along ``direction``; the other cameras as they are. Used
    either way round: the stale calibration of cameras that are ``rig``, or cameras moved since ``rig``."""
    if name not in rig.names:
        raise ValueError(f"camera {name}: not in the rig (cameras {list(rig.names)})")
    axis, direction = (np.asarray(v, dtype=np.float64) / np.linalg.norm(v) for v in (axis, direction))
    cams = []
    for cam in rig:
        if cam.name == name:
            rot = rodrigues_to_matrix(np.radians(rotation_deg) * axis) @ cam.rotation
            centre = cam.center_mm + shift_mm * direction
            cam = cam.replace(rvec=rvec_of(rot), tvec_mm=-rot @ centre)
        cams.append(cam)
    return Rig(tuple(cams))


def seen_from(det: MultiViewKeypoints, rig: Rig, moved: Rig, name: str) -> MultiViewKeypoints:
    """Real or simulated detections ``det`` (seen by the cameras ``rig``) as camera ``name`` would have seen
    them from its pose in ``moved``: each of its keypoints displaced by the image motion (px) of its point
    triangulated from all cameras, so the detector's own placement of each joint is kept. A reference trial
    recorded before a camera moved, made from one recorded after."""
    pts = robust_triangulate(det, rig).points_mm.reshape(-1, 3)
    ok = np.isfinite(pts).all(-1)
    shift = np.zeros((len(pts), 2))
    shift[ok] = moved[name].project(pts[ok])[:, :2] - rig[name].project(pts[ok])[:, :2]
    kp = det.one_person.copy()
    kp[list(det.camera_names).index(name), ..., :2] += shift.reshape(det.shape[1], det.shape[3], 2)
    return MultiViewKeypoints.of_one_person(kp, det.camera_names, det.times_s, det.skeleton)
