"""Board pose in each single view (PnP), with the detector's order ambiguities resolved by visibility.

A plain checkerboard's corners may come back rotated by 180 degrees or mirrored. A mirrored order still
reprojects perfectly but puts the board's printed face AWAY from the camera, which is impossible for an
opaque board; such candidates are dropped here. The 180-degree ambiguity cannot be decided in one view
and is resolved across cameras in :mod:`gaitcap.reconstruction.calibration.graph`.

A board whose corners carry ids (ChArUco) has no such ambiguity, and may be seen from either side: a
board printed on both faces (the back as the mirror image, as caliscope prints them) is found from
behind in the mirrored image, so the front-facing test is not applied to it.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from gaitcap.reconstruction.calibration.geometry import BoardObservations
from gaitcap.reconstruction.calibration.intrinsics import Intrinsics

MAX_PNP_MEDIAN_PX = 3.0  # a few misplaced corners must not throw away the view
PNP_OUTLIER_PX = 3.0


@dataclass(frozen=True, eq=False)
class ViewPoses:
    """Board -> camera pose candidates for every view.

    Attributes:
        rotation: (C, F, S, 3, 3) board -> camera rotations, one per symmetry S of the board.
        tvec_mm: (C, F, S, 3) board -> camera translations, mm.
        valid: (C, F, S) bool: a front-facing pose that reprojects well.
    """

    rotation: np.ndarray
    tvec_mm: np.ndarray
    valid: np.ndarray


def _front_facing(rmat: np.ndarray, tvec: np.ndarray) -> bool:
    """The camera sees the printed face: the camera centre lies on the board's -z side."""
    return float((-rmat.T @ tvec)[2]) < 0


def _pnp(obj: np.ndarray, img: np.ndarray, intr: Intrinsics) -> tuple[np.ndarray, np.ndarray, np.ndarray] | None:
    """IPPE pose (rvec, tvec) and each corner's reprojection error (px), or None."""
    if len(obj) < 4:
        return None
    ok, rvec, tvec = cv2.solvePnP(obj, img, intr.matrix_px, intr.dist, flags=cv2.SOLVEPNP_IPPE)
    if not ok:
        return None
    proj, _ = cv2.projectPoints(obj, rvec, tvec, intr.matrix_px, intr.dist)
    return rvec, tvec, np.linalg.norm(proj[:, 0] - img, axis=-1)


def solve_view(obj: np.ndarray, img: np.ndarray, intr: Intrinsics) -> tuple[np.ndarray, np.ndarray, float]:
    """Board -> camera (R, t) and the median reprojection error (px). Corners far off the first fit
    (misplaced by the detector) are left out of a second fit, so they cannot tip the planar pose over."""
    first = _pnp(obj, img, intr)
    if first is None:
        return np.eye(3), np.zeros(3), np.inf
    rvec, tvec, err = first
    keep = err < max(PNP_OUTLIER_PX, 3 * float(np.median(err)))
    if not keep.all():
        second = _pnp(obj[keep], img[keep], intr)
        if second is not None:
            rvec, tvec, err = second
    return cv2.Rodrigues(rvec)[0], tvec.ravel(), float(np.median(err))


def view_poses(obs: BoardObservations, intrinsics: list[Intrinsics]) -> ViewPoses:
    """PnP for every usable view and every board symmetry; keeps front-facing, well-fitting poses."""
    c_count, f_count, _ = obs.shape
    syms = np.asarray(obs.board.symmetries)
    rot = np.tile(np.eye(3), (c_count, f_count, len(syms), 1, 1))
    tvec = np.zeros((c_count, f_count, len(syms), 3))
    valid = np.zeros((c_count, f_count, len(syms)), dtype=bool)
    seen, views = obs.seen(), obs.views()
    one_order = len(syms) == 1  # corners with ids: a view from the back is a mirror-printed back side
    for c in range(c_count):
        for f in np.flatnonzero(views[c]):
            img = obs.corners_px[c, f][seen[c, f]]
            for s, perm in enumerate(syms):
                obj = obs.board.object_points_mm[perm[seen[c, f]]]
                r, t, median = solve_view(obj, img, intrinsics[c])
                rot[c, f, s], tvec[c, f, s] = r, t
                facing = one_order or _front_facing(r, t)
                valid[c, f, s] = median < MAX_PNP_MEDIAN_PX and t[2] > 0 and facing
    return ViewPoses(rot, tvec, valid)
