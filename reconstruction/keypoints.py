"""The one multi-view keypoints type: everyone's 2D keypoints seen by C cameras over T frames
(:class:`MultiViewKeypoints`).

The trial recording's reader (:func:`gaitcap.acquisition.recording.reader.read_keypoints`), every importer
of other tools' files (:mod:`gaitcap.acquisition.importers.keypoint_files`), the video detector, the completion after
Stop and the simulator return it; association takes it as input; reconstruction takes the patient's
keypoints of one person (P == 1: :meth:`MultiViewKeypoints.patient`, or the patient chosen among several
people) and reads them as :attr:`MultiViewKeypoints.one_person`. The bus message (:mod:`gaitcap.acquisition.keypoint_message`) is the
wire format, parsed once by the reader."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.ignored_keypoints import IgnoredKeypoints
from gaitcap.reconstruction.skeletons import Skeleton, get_skeleton

MISSING, LIVE, COMPLETED = 0, 1, 2  # provenance of a camera's frame
PROVENANCE = {MISSING: "missing", LIVE: "live", COMPLETED: "completed"}


def validate_keypoints(keypoints, camera_names, times_s, skeleton: Skeleton | str, *, layout: str
                       ) -> tuple[np.ndarray, tuple[str, ...], np.ndarray, Skeleton]:
    """Check keypoints laid out as ``layout`` ("(C, T, J, 3)" or "(C, T, P, J, 3)") against their
    camera names (C,), frame times (T,) s and skeleton; ValueError naming the field that is wrong."""
    kp = np.asarray(keypoints, dtype=np.float64)
    names = tuple(str(n) for n in camera_names)
    skel = get_skeleton(skeleton) if isinstance(skeleton, str) else skeleton
    ndim = layout.count(",") + 1
    if kp.ndim != ndim or kp.shape[-1] != 3:
        raise ValueError(f"keypoints: expected shape {layout}, got {kp.shape}")
    c, t, j = kp.shape[0], kp.shape[1], kp.shape[-2]
    if len(names) != c:
        raise ValueError(f"camera_names: {len(names)} names for {c} cameras in keypoints")
    if len(set(names)) != c:
        raise ValueError(f"camera_names: duplicates in {list(names)}")
    if j != skel.num_joints:
        raise ValueError(f"keypoints: {j} joints but skeleton {skel.name} has {skel.num_joints}")
    times = np.asarray(times_s, dtype=np.float64).reshape(-1)
    if times.shape != (t,):
        raise ValueError(f"times_s: expected {t} times (one per frame), got {times.shape[0]}")
    if t > 1 and not np.all(np.diff(times) > 0):
        raise ValueError("times_s: must be strictly increasing")
    conf = kp[..., 2]
    if np.any(np.isfinite(conf) & ((conf < 0) | (conf > 1))):
        raise ValueError("keypoints: confidence (last channel) must lie in [0, 1]")
    return kp, names, times, skel


def confident_mask(keypoints: np.ndarray, threshold: float) -> np.ndarray:
    """(..., J) bool of keypoints (..., J, 3): finite x, y and confidence > threshold."""
    return np.isfinite(keypoints).all(-1) & (np.nan_to_num(keypoints[..., 2]) > threshold)


def set_validated_fields(obj, *, layout: str) -> None:
    """Validate a frozen dataclass's keypoints, camera_names, times_s and skeleton and store the
    normalised values (arrays as float64, names as a tuple, the skeleton as a :class:`Skeleton`)."""
    values = validate_keypoints(obj.keypoints, obj.camera_names, obj.times_s, obj.skeleton, layout=layout)
    for name, value in zip(("keypoints", "camera_names", "times_s", "skeleton"), values, strict=True):
        object.__setattr__(obj, name, value)


@dataclass(frozen=True, eq=False)
class MultiViewKeypoints:
    """Everyone's keypoints from a recording, an imported file, videos or a simulation.

    Attributes:
        keypoints: (C, T, P, J, 3) float: x px, y px, confidence in [0, 1]; P = most people seen in one
            camera frame, in no particular order across cameras and frames (readers put the most confident
            first in each camera frame). Empty slots are NaN or have confidence 0.
        camera_names: (C,) names, matched to the calibration by name.
        times_s: (T,) frame times in s (strictly increasing; a recording's: since its first frame set,
            the median camera timestamp per frame id).
        skeleton: the keypoint layout (J joints); a registry name is accepted.
        frame_ids: (T,) int consecutive frame ids; default 0..T-1.
        timestamps_ns: (C, T) int camera timestamps, -1 where the camera's frame is missing; default
            ``times_s`` in ns for every camera.
        provenance: (C, T) uint8 per camera frame: :data:`MISSING` (no frame), :data:`LIVE` (keypoints as
            detected when the frame was taken, or as read from a file) or :data:`COMPLETED` (detected after
            Stop from the recorded image); default LIVE where the frame has a timestamp, else MISSING.
        restarts: {camera: times its frame counter started again within the recording}; those frames are
            placed by timestamp.
        ignored: {camera: its keypoint messages left out (stray frame ids, timestamps far off, unreadable)}
            for the cameras that had any; a camera with no message left is not in ``camera_names``.
    """

    keypoints: np.ndarray
    camera_names: tuple[str, ...]
    times_s: np.ndarray
    skeleton: Skeleton
    frame_ids: np.ndarray | None = None
    timestamps_ns: np.ndarray | None = None
    provenance: np.ndarray | None = None
    restarts: dict[str, int] = field(default_factory=dict)
    ignored: dict[str, IgnoredKeypoints] = field(default_factory=dict)

    def __post_init__(self) -> None:
        set_validated_fields(self, layout="(C, T, P, J, 3)")
        c, t = self.keypoints.shape[:2]
        ids = np.arange(t) if self.frame_ids is None else np.asarray(self.frame_ids)
        if ids.shape != (t,) or not np.issubdtype(ids.dtype, np.integer):
            raise ValueError(f"frame_ids: expected {t} integer ids (one per frame), got {ids.dtype} {ids.shape}")
        stamps = (np.broadcast_to(np.round(self.times_s * 1e9).astype(np.int64), (c, t)).copy()
                  if self.timestamps_ns is None else np.asarray(self.timestamps_ns))
        if stamps.shape != (c, t) or not np.issubdtype(stamps.dtype, np.integer):
            raise ValueError(f"timestamps_ns: expected ({c}, {t}) integer ns (cameras, frames), got "
                             f"{stamps.dtype} {stamps.shape}")
        prov = (np.where(stamps >= 0, LIVE, MISSING).astype(np.uint8) if self.provenance is None
                else np.asarray(self.provenance))
        if prov.shape != (c, t) or not np.isin(prov, list(PROVENANCE)).all():
            raise ValueError(f"provenance: expected ({c}, {t}) codes in {PROVENANCE} (cameras, frames), got "
                             f"{prov.shape} with {sorted(set(np.unique(prov).tolist()) - set(PROVENANCE))[:5]}")
        for name, value in (("frame_ids", ids.astype(np.int64)), ("timestamps_ns", stamps.astype(np.int64)),
                            ("provenance", prov.astype(np.uint8))):
            object.__setattr__(self, name, value)

    @property
    def shape(self) -> tuple[int, int, int, int]:
        """(C, T, P, J)."""
        c, t, p, j, _ = self.keypoints.shape
        return c, t, p, j

    @property
    def fps_hz(self) -> float:
        """Frames per second: 1 / the median frame period (NaN with fewer than two frames)."""
        return 1.0 / float(np.median(np.diff(self.times_s))) if self.times_s.size > 1 else float("nan")

    @property
    def one_person(self) -> np.ndarray:
        """(C, T, J, 3) keypoints of the one person that reconstruction takes; ValueError unless P == 1."""
        if self.keypoints.shape[2] != 1:
            raise ValueError(f"keypoints: reconstruction takes one person (P == 1), got P = {self.keypoints.shape[2]}")
        return self.keypoints[:, :, 0]

    @classmethod
    def of_one_person(cls, keypoints, camera_names, times_s, skeleton: Skeleton | str, **facts) -> MultiViewKeypoints:
        """One person's keypoints (C, T, J, 3) as P == 1; ``facts`` are the other fields (frame_ids, ...)."""
        kp = np.asarray(keypoints, dtype=np.float64)
        if kp.ndim != 4:
            raise ValueError(f"keypoints: expected shape (C, T, J, 3), got {kp.shape}")
        return cls(kp[:, :, None], camera_names, times_s, skeleton, **facts)

    def frames(self, index) -> MultiViewKeypoints:
        """These keypoints at frames ``index`` (a slice or increasing indices over T), with their frame ids,
        camera timestamps and provenance; ``restarts`` and ``ignored`` (counts over the whole recording) as
        they are."""
        return MultiViewKeypoints(self.keypoints[:, index], self.camera_names, self.times_s[index], self.skeleton,
                                  frame_ids=self.frame_ids[index], timestamps_ns=self.timestamps_ns[:, index],
                                  provenance=self.provenance[:, index], restarts=self.restarts, ignored=self.ignored)

    def confident(self, threshold: float = 0.5) -> np.ndarray:
        """(C, T, P, J) bool: finite x, y and confidence > threshold."""
        return confident_mask(self.keypoints, threshold)

    def aligned_to(self, rig: Rig) -> tuple[MultiViewKeypoints, Rig]:
        """These keypoints and the rig restricted to their cameras, in their order; ValueError naming the
        cameras that are not in the calibration."""
        return self, rig.subset(self.camera_names)

    def patient(self) -> MultiViewKeypoints:
        """keypoints[:, :, :1] of every frame (the first person, P == 1) as reconstruction input, with the
        frame ids, timestamps and provenance kept."""
        c, t, p, j = self.shape
        kp = self.keypoints[:, :, 0] if p else missing_keypoints((c, t, j))
        return self.of_one_person(kp, self.camera_names, self.times_s, self.skeleton, frame_ids=self.frame_ids,
                                  timestamps_ns=self.timestamps_ns, provenance=self.provenance,
                                  restarts=self.restarts, ignored=self.ignored)


def missing_keypoints(shape: tuple[int, ...]) -> np.ndarray:
    """Keypoints of ``shape`` + (3,) that were not seen: NaN pixels, confidence 0."""
    out = np.full((*shape, 3), np.nan)
    out[..., 2] = 0.0
    return out
