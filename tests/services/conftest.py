"""Helpers for the worker tests: a synthetic trial written as the recorder writes it (keypoints and
calibration in a trial MCAP; no image frames, which the worker does not read)."""

from pathlib import Path

from gaitcap.acquisition.boards.detection import BoardConfig, make_board
from gaitcap.simulator.board import BoardMotion, board_trajectory, render_board_images, scaled_rig
from gaitcap.simulator.recording import write_keypoint_recording
from gaitcap.simulator.room import build_rig


def write_trial_mcap(trial, path: Path, *, metadata: dict | None = None) -> Path:
    """The synthetic trial's patient detections as a trial MCAP (frame ids 0.., camera clocks in ns)."""
    return write_keypoint_recording(trial, path, metadata=metadata)


def write_multi_trial_mcap(trial, path: Path, *, stills: bool = False) -> Path:
    """Everyone's detections of a multi-person synthetic trial (``trial.multi``) as a trial MCAP: each
    camera frame lists the people detected in it, in the slots' (arbitrary) order. ``stills``: also a
    small grey image per camera and frame (so the recording has images to click on)."""
    return write_keypoint_recording(trial, path, everyone=True, stills=stills)


def board_images(scale: float = 0.3):
    """A checkerboard waved in front of cam01 and cam02 of the synthetic room (32 frames, 3 on the floor),
    rendered at ``scale`` of full size: ``(images per camera, the true rig scaled alike)``."""
    rig = build_rig(10, seed=0).subset(["cam01", "cam02"])
    board = make_board(BoardConfig.checkerboard())
    rot, tvec = board_trajectory(board.geometry, BoardMotion(n_frames=32, floor_frames=3, seed=3), rig)
    return render_board_images(rig, board, rot, tvec, scale=scale), scaled_rig(rig, scale)

