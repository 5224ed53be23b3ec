"""Compare two calibrations of the same cameras: a new one against a reference (the previous session's,
or the synthetic room's truth).

Two views of the difference: in the world frame as given (what a gait measurement sees: the floor and
walking axes included), and after the best rigid alignment of the camera centres (the rig's own shape,
independent of how the world frame was laid down). The change between the two world frames, found from
all cameras' orientations and centres, is reported as a floor tilt and a heading (yaw) turn plus a shift.
Two calibrations by different tools are compared after a similarity alignment (3 or more cameras), a
camera pair through its own geometry (the second camera seen from the first: :func:`stereo_difference`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.calibration.geometry import mean_rotation, rotation_angle_deg
from gaitcap.reconstruction.camera import Camera, Rig


@dataclass(frozen=True)
class CameraDifference:
    """One camera: centre distance (mm), rotation angle (deg), focal length change (%), both in the world
    frame as given; ``aligned_centre_mm``: centre distance once the common world change (turn and shift,
    from all cameras' orientations and centres) is taken out: the rig's own shape."""

    name: str
    centre_mm: float
    rotation_deg: float
    focal_pct: float
    aligned_centre_mm: float


@dataclass(frozen=True)
class RigComparison:
    """Per-camera differences and the world-frame difference (tilt of z, turn about z, shift of the origin)."""

    cameras: tuple[CameraDifference, ...]
    world_tilt_deg: float
    world_heading_deg: float
    world_shift_mm: float

    @property
    def centre_mm_max(self) -> float:
        return max(c.centre_mm for c in self.cameras)

    @property
    def rotation_deg_max(self) -> float:
        return max(c.rotation_deg for c in self.cameras)

    @property
    def aligned_centre_mm_max(self) -> float:
        return max(c.aligned_centre_mm for c in self.cameras)


def world_change(reference: list, other: list) -> tuple[np.ndarray, np.ndarray]:
    """The world change (W (3, 3), s (3,) mm) with X_other = W X_ref + s that best explains both rigs'
    camera orientations (W = mean of R_other^T R_ref) and centres (s = mean of c_other - W c_ref)."""
    turn = mean_rotation(np.stack([b.rotation.T @ a.rotation for a, b in zip(reference, other, strict=True)]))
    shift = np.mean([b.center_mm - turn @ a.center_mm for a, b in zip(reference, other, strict=True)], axis=0)
    return turn, shift


def compare_rigs(reference: Rig, other: Rig) -> RigComparison:
    """Differences of ``other`` from ``reference``; both must hold the same camera names (ValueError)."""
    if sorted(reference.names) != sorted(other.names):
        raise ValueError(f"compare: the calibrations hold different cameras: {sorted(reference.names)} vs "
                         f"{sorted(other.names)}")
    ref = [reference[n] for n in reference.names]
    got = [other[n] for n in reference.names]
    turn, shift = world_change(ref, got)
    aligned = [turn.T @ (b.center_mm - shift) for b in got]  # other's centres in the reference's world
    cams = tuple(
        CameraDifference(
            a.name, float(np.linalg.norm(a.center_mm - b.center_mm)), rotation_angle_deg(a.rotation, b.rotation),
            float(100 * (b.matrix_px[0, 0] / a.matrix_px[0, 0] - 1)), float(np.linalg.norm(al - a.center_mm)),
        )
        for a, b, al in zip(ref, got, aligned, strict=True)
    )
    tilt = float(np.degrees(np.arccos(np.clip(turn[2, 2], -1.0, 1.0))))
    heading = float(np.degrees(np.arctan2(turn[1, 0] - turn[0, 1], turn[0, 0] + turn[1, 1])))
    return RigComparison(cams, tilt, abs(heading), float(np.linalg.norm(shift)))


@dataclass(frozen=True)
class SimilarityComparison:
    """Two calibrations from different tools (own world frames and units) compared after the similarity
    (scale, turn, shift) that best puts ``other``'s camera centres on the reference's (least squares).

    scale: reference length per ``other`` length (1.0 when both measure the same board in mm);
    centre_mm / rotation_deg: per camera, in the order of ``names``;
    pointing_deg: per camera, the angle between the two calibrations' viewing rays through the image's
    centre pixel (intrinsics included). A principal point placed elsewhere turns the camera by as much
    (e.g. 20 px at a 640 px focal length: 1.8 deg), so two calibrations whose principal points differ
    can disagree on the rotation while their rays agree; this says which.
    """

    names: tuple[str, ...]
    scale: float
    centre_mm: tuple[float, ...]
    rotation_deg: tuple[float, ...]
    pointing_deg: tuple[float, ...] = ()

    @property
    def centre_mm_max(self) -> float:
        return max(self.centre_mm)

    @property
    def rotation_deg_max(self) -> float:
        return max(self.rotation_deg)


def similarity_transform(src: np.ndarray, dst: np.ndarray) -> tuple[float, np.ndarray, np.ndarray]:
    """Umeyama: (s, R (3, 3), t (3,)) minimising |dst - (s R src + t)|^2 over points (P, 3), P >= 3."""
    mu_s, mu_d = src.mean(0), dst.mean(0)
    a, b = src - mu_s, dst - mu_d
    u, sing, vt = np.linalg.svd(b.T @ a / len(src))
    d = np.diag([1.0, 1.0, np.sign(np.linalg.det(u @ vt))])
    rot = u @ d @ vt
    scale = float(np.trace(np.diag(sing) @ d) / np.mean(np.sum(a**2, -1)))
    return scale, rot, mu_d - scale * rot @ mu_s


def compare_similar(reference: Rig, other: Rig) -> SimilarityComparison:
    """``other`` against ``reference`` after a similarity alignment of the camera centres (ValueError
    when the camera names differ or fewer than 3 cameras leave the alignment undetermined)."""
    if sorted(reference.names) != sorted(other.names):
        raise ValueError(f"compare: the calibrations hold different cameras: {sorted(reference.names)} vs "
                         f"{sorted(other.names)}")
    names = tuple(reference.names)
    if len(names) < 3:
        raise ValueError(f"compare: a similarity alignment needs 3 or more cameras, got {len(names)}")
    ref = np.stack([reference[n].center_mm for n in names])
    got = np.stack([other[n].center_mm for n in names])
    scale, rot, shift = similarity_transform(got, ref)
    aligned = scale * got @ rot.T + shift
    centre = tuple(float(x) for x in np.linalg.norm(aligned - ref, axis=1))
    rotation = tuple(rotation_angle_deg(reference[n].rotation, other[n].rotation @ rot.T) for n in names)
    pointing = tuple(_ray_angle_deg(reference[n], other[n], rot) for n in names)
    return SimilarityComparison(names, scale, centre, tuple(float(r) for r in rotation), pointing)


def _centre_ray(cam: Camera) -> np.ndarray:
    """Unit viewing ray (3,) through the image's centre pixel, in the camera's world frame."""
    from gaitcap.reconstruction.association.geometry import pixel_rays  # here: the package is heavy to import

    _, rays = pixel_rays(Rig((cam,)), np.array([[cam.size_px[0] / 2, cam.size_px[1] / 2]], dtype=np.float64))
    return rays[0]


def _ray_angle_deg(reference: Camera, other: Camera, turn: np.ndarray) -> float:
    """Angle (degrees) between the centre-pixel rays of two calibrations of one camera, ``other``'s turned
    into the reference's frame by ``turn`` (3, 3)."""
    cos = float(np.clip(_centre_ray(reference) @ (turn @ _centre_ray(other)), -1.0, 1.0))
    return float(np.degrees(np.arccos(cos)))


@dataclass(frozen=True)
class StereoDifference:
    """The second camera as seen from the first, in two calibrations of a pair: baselines (mm), the
    distance between the two places of its centre (mm) and the angle between the two relative rotations
    (deg). Independent of each calibration's world frame."""

    baseline_mm: float
    reference_baseline_mm: float
    centre_mm: float
    rotation_deg: float


def _second_from_first(rig: Rig, first: str, second: str) -> tuple[np.ndarray, np.ndarray]:
    a, b = rig[first], rig[second]
    rot = b.rotation @ a.rotation.T
    return rot, a.to_camera(b.center_mm)  # relative rotation, second centre in the first camera's frame (mm)


def stereo_difference(reference: Rig, other: Rig, *, first: str, second: str) -> StereoDifference:
    """``other``'s pair geometry against ``reference``'s (both must hold both cameras: ValueError)."""
    for rig, what in ((reference, "reference"), (other, "other")):
        missing = [n for n in (first, second) if n not in rig.names]
        if missing:
            raise ValueError(f"stereo_difference: the {what} calibration has no camera {missing} (it has {rig.names})")
    rot_ref, centre_ref = _second_from_first(reference, first, second)
    rot, centre = _second_from_first(other, first, second)
    return StereoDifference(float(np.linalg.norm(centre)), float(np.linalg.norm(centre_ref)),
                            float(np.linalg.norm(centre - centre_ref)), rotation_angle_deg(rot_ref, rot))
