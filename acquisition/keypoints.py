"""The one multi-view keypoints type: everyone's 2D keypoints seen by C cameras over T frames
(:class:`KeypointRecording`). The trial recording's reader
(:func:`gaitcap.acquisition.recording.reader.read_keypoints`) and every importer of other tools' files
(:mod:`gaitcap.acquisition.keypoint_files`, through :func:`gaitcap.acquisition.keypoint_input.as_recording`)
return it; the bus message (:mod:`gaitcap.acquisition.keypoint_message`) is the wire format, parsed once by
the reader. Reconstruction takes the patient's :class:`~gaitcap.reconstruction.detections.Detections` of it
(:meth:`KeypointRecording.patient`, or the patient chosen among several people)."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from gaitcap.acquisition.recording.ignored import IgnoredKeypoints
from gaitcap.reconstruction.detections import Detections


@dataclass(frozen=True, eq=False)
class KeypointRecording:
    """Every person's keypoints from a recording or an imported file.

    Attributes:
        camera_names: (C,).
        frame_ids: (T,) consecutive frame ids from the first to the last seen.
        times_s: (T,) s since the first frame set (median camera timestamp per frame id).
        skeleton: skeleton name.
        people: (C, T, P, J, 3) x px, y px, conf; P = most people seen in one frame; missing: NaN, conf 0.
        timestamps_ns: (C, T) camera timestamps, -1 where the frame is missing.
        restarts: {camera: times its frame counter started again within the recording}; those frames are
            placed by timestamp.
        ignored: {camera: its keypoint messages left out (stray frame ids, timestamps far off, unreadable)}
            for the cameras that had any; a camera with no message left is not in ``camera_names``.
    """

    camera_names: tuple[str, ...]
    frame_ids: np.ndarray
    times_s: np.ndarray
    skeleton: str
    people: np.ndarray
    timestamps_ns: np.ndarray
    restarts: dict[str, int] = field(default_factory=dict)
    ignored: dict[str, IgnoredKeypoints] = field(default_factory=dict)

    def patient(self) -> Detections:
        """people[0] of every frame (the detector's first person) as reconstruction input."""
        c, t, _, j, _ = self.people.shape
        kp = self.people[:, :, 0] if self.people.shape[2] else missing_keypoints((c, t, j))
        return Detections(kp, self.camera_names, self.times_s, self.skeleton)


def missing_keypoints(shape: tuple[int, ...]) -> np.ndarray:
    """Keypoints of ``shape`` + (3,) that were not seen: NaN pixels, confidence 0."""
    out = np.full((*shape, 3), np.nan)
    out[..., 2] = 0.0
    return out
