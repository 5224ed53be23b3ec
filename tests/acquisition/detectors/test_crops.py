"""Crops: the affine map between crop and image pixels, and resampling."""

import numpy as np
import pytest
from gaitcap.acquisition.detectors.crops import Crop, box_crop, square_crop


def test_round_trip_and_rotation():
    crop = square_crop(np.array([100.0, 50.0]), 40.0, np.pi / 2, 20)
    # Crop centre -> image centre; the crop's +y axis points to image -x at 90 degrees; 2 image px per crop px.
    np.testing.assert_allclose(crop.to_image(np.array([10.0, 10.0])), [100, 50])
    np.testing.assert_allclose(crop.to_image(np.array([10.0, 15.0])), [90, 50])
    np.testing.assert_allclose(crop.to_image(np.array([15.0, 10.0])), [100, 60])


def test_warp_samples_the_mapped_pixels():
    img = np.zeros((60, 80, 3), np.uint8)
    img[30, 50] = 255
    crop = Crop((50.0, 30.0), (20.0, 20.0), 0.3, (20, 20))
    patch = crop.warp(img)
    y, x = np.unravel_index(np.argmax(patch[..., 0]), patch.shape[:2])
    np.testing.assert_allclose(crop.to_image(np.array([x, y], float)), [50, 30], atol=1.0)
    edge = Crop((0.0, 0.0), (20.0, 20.0), 0.0, (20, 20))
    ones = np.full((60, 80, 3), 9, np.uint8)
    assert edge.warp(ones)[0, 0, 0] == 0 and edge.warp(ones, replicate=True)[0, 0, 0] == 9


def test_box_crop_pads_and_keeps_the_output_aspect():
    crop = box_crop(np.array([10, 20, 50, 100]), out_size_px=(192, 256), padding=1.25)
    assert crop.center_px == (30.0, 60.0)
    w, h = crop.size_px
    assert h == pytest.approx(100) and w / h == pytest.approx(192 / 256)
    with pytest.raises(ValueError, match="x1 > x0"):
        box_crop(np.array([5, 0, 5, 10]), out_size_px=(10, 10))
