"""Images of a calibration board seen by one synthetic camera: every pixel's ray meets the board's
plane, where the printed texture (or the blank back of an opaque board) is sampled; the board's box is
rendered at ``supersample`` x and averaged down, and Gaussian grey-level noise is added. A board moving
during the exposure is smeared (:class:`Exposure`: the image averaged over poses spread across it)."""

from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np
from gaitcap.acquisition.boards.detection import Board
from gaitcap.reconstruction.camera import Camera
from gaitcap.simulator.room import safe_project

PX_PER_MM = 2.0  # texture resolution


@dataclass(frozen=True)
class Exposure:
    """A board moving while the shutter is open: motion blur.

    velocity_mm_s: (3,) world velocity of the board, mm/s; exposure_s: open time, s; samples: poses
    averaged across it (the frame's pose sits in the middle of the exposure).
    """

    velocity_mm_s: tuple[float, float, float] = (0.0, 0.0, 0.0)
    exposure_s: float = 0.0
    samples: int = 9

    def __post_init__(self) -> None:
        if self.exposure_s < 0 or self.samples < 1:
            raise ValueError(f"exposure: exposure_s must be >= 0 and samples >= 1, got {self.exposure_s}, "
                             f"{self.samples}")

    def offsets_mm(self) -> np.ndarray:
        """(S, 3) board shifts, mm, at the sampled instants of the exposure."""
        if self.exposure_s == 0:
            return np.zeros((1, 3))
        times = (np.arange(self.samples) + 0.5) / self.samples - 0.5
        return np.outer(times * self.exposure_s, self.velocity_mm_s)


def camera_at(cam: Camera, scale: float) -> Camera:
    """The camera imaged at ``scale`` x its resolution (pixel centres stay at integers)."""
    return camera_resized(cam, tuple(int(round(v * scale)) for v in cam.size_px), scale_xy=(scale, scale))


def camera_resized(cam: Camera, size_px: tuple[int, int], scale_xy: tuple[float, float] | None = None) -> Camera:
    """The camera imaged at ``size_px`` (width, height): its sensor image resized, per axis by
    ``scale_xy`` (default: size / sensor size), pixel centres kept at integers."""
    sx, sy = scale_xy or (size_px[0] / cam.size_px[0], size_px[1] / cam.size_px[1])
    k = cam.matrix_px.copy()
    k[0] *= sx
    k[1] *= sy
    k[0, 2] = (cam.matrix_px[0, 2] + 0.5) * sx - 0.5
    k[1, 2] = (cam.matrix_px[1, 2] + 0.5) * sy - 0.5
    return cam.replace(matrix_px=k, size_px=(int(size_px[0]), int(size_px[1])))


def _pixel_rays(cam: Camera) -> np.ndarray:
    """Undistorted normalised coordinates (H, W, 2) float32 of every pixel centre of the camera."""
    w, h = cam.size_px
    yy, xx = np.mgrid[0:h, 0:w].astype(np.float32)
    pts = np.stack([xx.ravel(), yy.ravel()], 1).reshape(-1, 1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 30, 1e-10)
    xy = cv2.undistortPoints(pts, cam.matrix_px, cam.dist, None, None, None, crit)
    return xy.reshape(h, w, 2).astype(np.float32)


def _board_box(cam: Camera, outline_mm: np.ndarray, r_b: np.ndarray, t_b: np.ndarray) -> tuple[int, int, int, int] | None:
    """Pixel box (x0, y0, x1, y1) that holds the board's image, or None when it is out of view."""
    edges = np.concatenate([np.linspace(outline_mm[i], outline_mm[(i + 1) % 4], 16) for i in range(4)])
    px = safe_project(cam, edges @ r_b.T + t_b)
    if np.isnan(px).any():
        return (0, 0, *cam.size_px)  # partly behind the camera: render the whole image
    w, h = cam.size_px
    pad = 0.05 * np.ptp(px, axis=0) + 3
    x0, y0 = np.maximum(np.floor(px.min(0) - pad), 0).astype(int)
    x1, y1 = np.minimum(np.ceil(px.max(0) + pad), [w, h]).astype(int)
    return None if x0 >= x1 or y0 >= y1 else (x0, y0, x1, y1)


class BoardRenderer:
    """Renders one camera's view of the board at ``size_px`` (width, height; the camera's sensor image
    resized, see :func:`camera_resized` for the matching intrinsics).

    The pixel rays are computed once (the costly part); each :meth:`render` then costs about the board's
    area in pixels.
    """

    def __init__(self, cam: Camera, board: Board, *, size_px: tuple[int, int], supersample: int = 2,
                 noise_gray: float = 2.0, background: int = 110) -> None:
        self.ss, self.noise_gray, self.background = supersample, noise_gray, background
        self.size_px = (int(size_px[0]), int(size_px[1]))
        self.cam = camera_resized(cam, (self.size_px[0] * supersample, self.size_px[1] * supersample))
        self.rays = _pixel_rays(self.cam)
        self.texture, self.corner0_px = board.texture(PX_PER_MM)
        self.back = np.full_like(self.texture, 200)
        th, tw = self.texture.shape
        outline = np.array([[0, 0], [tw, 0], [tw, th], [0, th]]) - 0.5 - self.corner0_px
        self.outline_mm = np.column_stack([outline / PX_PER_MM, np.zeros(4)])

    def render(self, r_b: np.ndarray, t_b: np.ndarray, rng: np.random.Generator,
               exposure: Exposure | None = None) -> np.ndarray:
        """Grey image (H, W) uint8 of the board at pose board -> world (r_b (3, 3), t_b (3,) mm), smeared
        over ``exposure`` when given."""
        w, h = self.size_px
        shifts = (exposure or Exposure()).offsets_mm()
        img = np.zeros((h, w), dtype=np.float32)
        for shift in shifts:
            img += self._sharp(r_b, t_b + shift)
        img = img / len(shifts) + self.noise_gray * rng.standard_normal((h, w), dtype=np.float32)
        return np.clip(img, 0, 255).astype(np.uint8)

    def _sharp(self, r_b: np.ndarray, t_b: np.ndarray) -> np.ndarray:
        """Noise-free grey image (H, W) float32 of the board at one pose."""
        w, h = self.size_px
        img = np.full((h, w), float(self.background), dtype=np.float32)
        box = _board_box(self.cam, self.outline_mm, r_b, t_b)
        if box is not None:  # render the board's box at supersample x, then average it down
            x0, y0 = (v // self.ss for v in box[:2])
            x1, y1 = min(-(-box[2] // self.ss), w), min(-(-box[3] // self.ss), h)
            patch = self._patch((x0, y0, x1, y1), r_b, t_b)
            img[y0:y1, x0:x1] = cv2.resize(patch, (x1 - x0, y1 - y0), interpolation=cv2.INTER_AREA)
        return img

    def _patch(self, box: tuple[int, int, int, int], r_b: np.ndarray, t_b: np.ndarray) -> np.ndarray:
        """The supersampled pixels (uint8) of the output box (x0, y0, x1, y1)."""
        ss = self.ss
        xy = self.rays[box[1] * ss:box[3] * ss, box[0] * ss:box[2] * ss]
        o = r_b.T @ (self.cam.center_mm - t_b)  # camera centre in the board frame
        m = (r_b.T @ self.cam.rotation.T).astype(np.float32)  # camera ray -> board-frame direction
        d = xy @ m[:, :2].T + m[:, 2]  # (bh, bw, 3)
        lam = -o[2] / np.where(np.abs(d[..., 2:]) < 1e-9, 1e-9, d[..., 2:])
        maps = ((o[:2] + lam * d[..., :2]) * PX_PER_MM + self.corner0_px).astype(np.float32)
        maps[lam[..., 0] <= 0] = -1e6
        return cv2.remap(self.texture if o[2] < 0 else self.back, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR,
                         borderMode=cv2.BORDER_CONSTANT, borderValue=self.background)
