"""Every confident association joint of every detection as a world ray (the association's working data)."""

from __future__ import annotations

import contextlib
import warnings
from collections.abc import Iterator
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.association.config import AssociationConfig
from gaitcap.reconstruction.association.geometry import pixel_rays
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


@dataclass(frozen=True)
class Rays:
    origins_mm: np.ndarray  # (C, 3)
    dirs: np.ndarray  # (C, T, P, Ja, 3)
    mask: np.ndarray  # (C, T, P, Ja)
    pixels_px: np.ndarray  # (C, T, P, Ja, 2), NaN where not confident
    flip: np.ndarray  # (Ja,) index of each association joint's left/right mirror among them
    scale_px: np.ndarray  # (C, T, P) box diagonal of the detection


@contextlib.contextmanager
def quiet_warnings() -> Iterator[None]:
    """Silence numpy's 'mean of empty slice' (RuntimeWarning) inside a block."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", category=RuntimeWarning)
        yield


def make_rays(multi: MultiViewKeypoints, rig: Rig, jidx, config: AssociationConfig) -> Rays:
    conf_all = multi.confident(config.confidence_threshold)  # (C, T, P, J)
    kp = multi.keypoints
    xy = np.where(conf_all[..., None], kp[..., :2], np.nan)
    with quiet_warnings():
        span = np.nanmax(xy, axis=3) - np.nanmin(xy, axis=3)  # (C, T, P, 2)
    scale = np.hypot(span[..., 0], span[..., 1])
    mask = conf_all[:, :, :, jidx]
    mask &= (mask.sum(-1) >= config.min_joints)[..., None]
    pixels = np.where(mask[..., None], kp[:, :, :, jidx, :2], np.nan)
    origins, dirs = pixel_rays(rig, pixels)
    perm = multi.skeleton.flip_permutation
    flip = np.array([jidx.index(perm[j]) if perm[j] in jidx else i for i, j in enumerate(jidx)])
    return Rays(origins_mm=origins, dirs=dirs, mask=mask, pixels_px=pixels, flip=flip,
                 scale_px=np.nan_to_num(scale, nan=0.0))
