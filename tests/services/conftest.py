"""Helpers for the worker tests: a synthetic trial written as the recorder writes it (keypoints and
calibration in a trial MCAP; no image frames, which the worker does not read)."""

from pathlib import Path

from gaitcap.acquisition.synthetic.recording import write_keypoint_recording


def write_trial_mcap(trial, path: Path, *, metadata: dict | None = None) -> Path:
    """The synthetic trial's patient detections as a trial MCAP (frame ids 0.., camera clocks in ns)."""
    return write_keypoint_recording(trial, path, metadata=metadata)


def write_multi_trial_mcap(trial, path: Path, *, stills: bool = False) -> Path:
    """Everyone's detections of a multi-person synthetic trial (``trial.multi``) as a trial MCAP: each
    camera frame lists the people detected in it, in the slots' (arbitrary) order. ``stills``: also a
    small grey image per camera and frame (so the recording has images to click on)."""
    return write_keypoint_recording(trial, path, everyone=True, stills=stills)
