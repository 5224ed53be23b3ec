"""The detector registry and shared helpers."""

from dataclasses import dataclass

import gaitcap.acquisition.detectors  # noqa: F401  (registers every kind)
import numpy as np
import pytest
from gaitcap.acquisition.detectors.base import (
    DETECTOR_CONFIGS,
    DetectorConfig,
    best_person,
    check_image,
    config_class,
    register_detector,
)


def test_every_kind_is_registered():
    assert {"simulated", "mediapipe", "onnx"} <= set(DETECTOR_CONFIGS)
    assert config_class("onnx").kind == "onnx"
    with pytest.raises(ValueError, match="unknown detector 'yolo'.*mediapipe"):
        config_class("yolo")


def test_a_kind_cannot_be_registered_twice(monkeypatch):
    monkeypatch.setattr("gaitcap.acquisition.detectors.base.DETECTOR_CONFIGS", dict(DETECTOR_CONFIGS))

    @dataclass(frozen=True)
    class Other(DetectorConfig):
        kind = "onnx"

        def build(self):
            raise AssertionError

    with pytest.raises(ValueError, match="registered twice"):
        register_detector(Other)


def test_check_image_and_best_person():
    grey = check_image(np.zeros((4, 5), np.uint8), camera="c1")
    assert grey.shape == (4, 5, 3)
    with pytest.raises(ValueError, match="camera c1: expected a uint8"):
        check_image(np.zeros((4, 5, 3), np.float32), camera="c1")
    with pytest.raises(ValueError, match="camera c2: expected an \\(H, W, 3\\)"):
        check_image(np.zeros((4, 5, 4), np.uint8), camera="c2")
    people = np.zeros((3, 2, 3))
    people[1, :, 2] = [0.9, 0.8]
    people[2, :, 2] = [1.0, np.nan]
    assert best_person(people) == 1 and best_person(np.zeros((0, 2, 3))) is None
