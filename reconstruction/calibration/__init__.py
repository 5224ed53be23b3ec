"""Camera calibration from board recordings: pure maths on board observations (no I/O).

Entry point: :func:`calibrate_from_observations` (``BoardObservations`` -> ``CalibrationResult``).
Modules: ``geometry`` (board, observations, rotations), ``intrinsics`` (OpenCV per camera), ``views``
(single-view poses, detector order ambiguities), ``graph`` (camera graph, initial poses), ``bundle``
(robust bundle adjustment), ``world`` (floor-board frame), ``walk_frame`` (frame from a walk),
``report`` (quality report), ``pipeline`` (all of it), ``board_check`` (the board measured in 3D),
``holdout`` (the held-out error, k folds in time; a given calibration judged the same way),
``model_choice`` (intrinsics chosen by held-out error), ``coverage`` (board views per image cell and
camera pair while a board recording runs).
"""

from gaitcap.reconstruction.calibration.bundle import BundleConfig
from gaitcap.reconstruction.calibration.geometry import BoardGeometry, BoardObservations, grid_board
from gaitcap.reconstruction.calibration.intrinsics import DistortionModel, IntrinsicsConfig
from gaitcap.reconstruction.calibration.pipeline import (
    CalibrationConfig,
    CalibrationResult,
    calibrate_from_observations,
)
from gaitcap.reconstruction.calibration.report import CameraQuality, QualityReport, QualityThresholds
from gaitcap.reconstruction.calibration.walk_frame import reframe_rig, world_from_walk
from gaitcap.reconstruction.calibration.world import WorldFrameConfig

__all__ = [
    "BoardGeometry",
    "BoardObservations",
    "BundleConfig",
    "CalibrationConfig",
    "CalibrationResult",
    "CameraQuality",
    "DistortionModel",
    "IntrinsicsConfig",
    "QualityReport",
    "QualityThresholds",
    "WorldFrameConfig",
    "calibrate_from_observations",
    "grid_board",
    "reframe_rig",
    "world_from_walk",
]
