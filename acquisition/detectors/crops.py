"""Rotated rectangular crops of an image and the affine maps between crop and image pixels.

Top-down detectors crop a region around a person, resize it to the network's input size and map the
network's keypoints back. One :class:`Crop` holds that region; both directions use the same matrix, so
the round trip is exact up to float rounding.
"""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class Crop:
    """A rotated rectangle in the image, resampled to ``out_size_px``.

    Attributes:
        center_px: (2,) rectangle centre in image px (x, y).
        size_px: (2,) rectangle width and height in image px.
        rotation_rad: rotation of the rectangle; 0 means the crop's +y axis is the image's +y axis, and
            positive angles turn the crop's axes clockwise on screen (image y points down).
        out_size_px: (width, height) of the resampled crop in px.
    """

    center_px: tuple[float, float]
    size_px: tuple[float, float]
    rotation_rad: float
    out_size_px: tuple[int, int]

    def __post_init__(self) -> None:
        if not (self.size_px[0] > 0 and self.size_px[1] > 0):
            raise ValueError(f"crop size must be positive, got {self.size_px} px")
        if not np.all(np.isfinite(self.center_px)):
            raise ValueError(f"crop centre must be finite, got {self.center_px}")

    @property
    def crop_to_image(self) -> np.ndarray:
        """(2, 3) affine matrix: crop px (x, y, 1) -> image px."""
        ow, oh = self.out_size_px
        sx, sy = self.size_px[0] / ow, self.size_px[1] / oh
        c, s = np.cos(self.rotation_rad), np.sin(self.rotation_rad)
        lin = np.array([[c * sx, -s * sy], [s * sx, c * sy]])
        offset = np.asarray(self.center_px, dtype=np.float64) - lin @ np.array([ow / 2, oh / 2])
        return np.hstack([lin, offset[:, None]])

    def to_image(self, points_crop_px: np.ndarray) -> np.ndarray:
        """(..., 2) crop px -> (..., 2) image px."""
        m = self.crop_to_image
        return points_crop_px @ m[:, :2].T + m[:, 2]

    def warp(self, image: np.ndarray, *, border_value: float = 0.0, replicate: bool = False) -> np.ndarray:
        """Resample the crop from ``image`` (H, W, ch) -> (out_h, out_w, ch); outside the image filled with
        ``border_value``, or with the nearest edge pixel when ``replicate``."""
        return cv2.warpAffine(
            image,
            self.crop_to_image,
            tuple(int(v) for v in self.out_size_px),
            flags=cv2.INTER_LINEAR | cv2.WARP_INVERSE_MAP,
            borderMode=cv2.BORDER_REPLICATE if replicate else cv2.BORDER_CONSTANT,
            borderValue=(border_value,) * 3,
        )


def box_crop(box_xyxy_px: np.ndarray, *, out_size_px: tuple[int, int], padding: float = 1.25) -> Crop:
    """Axis-aligned crop around a box, enlarged by ``padding`` and to the output's aspect ratio.

    This is the usual top-down preprocessing (mmpose ``GetBBoxCenterScale`` + ``TopdownAffine``).
    """
    x0, y0, x1, y1 = (float(v) for v in box_xyxy_px)
    if not (x1 > x0 and y1 > y0):
        raise ValueError(f"person box must have x1 > x0 and y1 > y0, got {[x0, y0, x1, y1]}")
    w, h = (x1 - x0) * padding, (y1 - y0) * padding
    aspect = out_size_px[0] / out_size_px[1]
    if w > h * aspect:
        h = w / aspect
    else:
        w = h * aspect
    return Crop(((x0 + x1) / 2, (y0 + y1) / 2), (w, h), 0.0, out_size_px)


def square_crop(center_px: np.ndarray, side_px: float, rotation_rad: float, out_side_px: int) -> Crop:
    """Rotated square crop of side ``side_px`` resampled to ``out_side_px`` x ``out_side_px``."""
    return Crop(
        (float(center_px[0]), float(center_px[1])), (float(side_px), float(side_px)), float(rotation_rad),
        (int(out_side_px), int(out_side_px)),
    )
