"""Camera calibration from board recordings: pure maths on board observations (no I/O).

Entry point: :func:`calibrate_from_observations` (``BoardObservations`` -> ``CalibrationResult``).
"""

from reconstruction.calibration.bundle import BundleConfig
from reconstruction.calibration.geometry import BoardGeometry, BoardObservations, grid_board
from reconstruction.calibration.intrinsics import DistortionModel, IntrinsicsConfig
from reconstruction.calibration.pipeline import (
    CalibrationConfig,
    CalibrationResult,
    calibrate_from_observations,
)
from reconstruction.calibration.report import CameraQuality, QualityReport, QualityThresholds
from reconstruction.calibration.world import WorldFrameConfig

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
]
