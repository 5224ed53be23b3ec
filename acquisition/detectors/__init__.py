"""2D keypoint detectors: simulated (synthetic world), MediaPipe Pose (offline TFLite), ONNX top-down.

Importing this package registers every detector config in ``DETECTOR_CONFIGS`` (kind -> config class);
the models themselves load only in ``config.build()``.
"""

from gaitcap.acquisition.detectors import mediapipe, onnx, simulated  # noqa: F401  (register the configs)
from gaitcap.acquisition.detectors.base import DETECTOR_CONFIGS, Detector, DetectorConfig, config_class

__all__ = ["DETECTOR_CONFIGS", "Detector", "DetectorConfig", "config_class"]
