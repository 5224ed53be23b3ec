"""The 2D keypoint detector protocol and the registry of detector configs.

A detector turns one camera image into keypoints of the people it sees::

    detector.detect(image_bgr, camera="cam0", frame_id=12, timestamp_ns=...) -> (P, J, 3)

with x px, y px, confidence in [0, 1] per joint, P >= 0 people and J = ``detector.skeleton.num_joints``.

Detectors are chosen by typed, frozen configs (one small class per detector kind) kept in a registry:
``DETECTOR_CONFIGS["onnx"]`` is :class:`~gaitcap.acquisition.detectors.onnx.OnnxConfig`; ``config.build()``
returns the detector. Heavy libraries (onnxruntime, the TFLite interpreter) load inside ``build()``.
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import ClassVar, Protocol, runtime_checkable

import numpy as np
from gaitcap.reconstruction.skeletons import Skeleton

DETECTOR_CONFIGS: dict[str, type[DetectorConfig]] = {}


@runtime_checkable
class Detector(Protocol):
    """Anything with a skeleton and a ``detect`` method returning (P, J, 3) keypoints."""

    skeleton: Skeleton

    def detect(self, image_bgr: np.ndarray, *, camera: str, frame_id: int, timestamp_ns: int) -> np.ndarray:
        """image_bgr: (H, W, 3) uint8 -> (P, J, 3) float: x px, y px, confidence in [0, 1]."""
        ...


@dataclass(frozen=True)
class DetectorConfig(ABC):
    """Base of the typed detector configs; subclasses set ``kind`` and register themselves."""

    kind: ClassVar[str]

    @abstractmethod
    def build(self) -> Detector:
        """Load the model and return a ready detector."""


def register_detector(cls: type[DetectorConfig]) -> type[DetectorConfig]:
    """Class decorator: make a config class available as ``DETECTOR_CONFIGS[cls.kind]``."""
    if cls.kind in DETECTOR_CONFIGS and DETECTOR_CONFIGS[cls.kind] is not cls:
        raise ValueError(f"detector kind {cls.kind!r} registered twice")
    DETECTOR_CONFIGS[cls.kind] = cls
    return cls


def config_class(kind: str) -> type[DetectorConfig]:
    """The config class of a detector kind; ValueError listing the known kinds."""
    try:
        return DETECTOR_CONFIGS[kind]
    except KeyError:
        raise ValueError(f"unknown detector {kind!r}; known: {sorted(DETECTOR_CONFIGS)}") from None


def empty_keypoints(num_joints: int) -> np.ndarray:
    """(0, J, 3): no person found."""
    return np.zeros((0, num_joints, 3), dtype=np.float64)


def check_image(image_bgr: np.ndarray, *, camera: str) -> np.ndarray:
    """Validate an (H, W, 3) uint8 BGR image (or (H, W) grey, converted); ValueError naming the camera."""
    img = np.asarray(image_bgr)
    if img.ndim == 2:
        img = np.repeat(img[:, :, None], 3, axis=2)
    if img.ndim != 3 or img.shape[2] != 3 or img.shape[0] < 2 or img.shape[1] < 2:
        raise ValueError(f"camera {camera}: expected an (H, W, 3) BGR image, got shape {img.shape}")
    if img.dtype != np.uint8:
        raise ValueError(f"camera {camera}: expected a uint8 image, got {img.dtype}")
    return img


def best_person(people: np.ndarray) -> int | None:
    """Index of the person with the highest mean confidence in (P, J, 3), or None when P == 0."""
    if people.shape[0] == 0:
        return None
    conf = np.nan_to_num(people[..., 2]).mean(axis=1)
    return int(np.argmax(conf))
