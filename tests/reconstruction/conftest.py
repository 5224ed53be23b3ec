"""Shared fixtures for reconstruction tests: small synthetic rigs and noisy detections."""

import numpy as np
import pytest
from gaitcap.reconstruction.camera import Camera, Rig, matrix_to_rodrigues
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import get_skeleton


def _ring_rig(n: int = 6, radius_mm: float = 4000.0, dist=(-0.12, 0.02, 0.0005, -0.0005, 0.0)) -> Rig:
    """n cameras on a circle at 1.5 m height, all looking at (0, 0, 900) mm."""
    cams = []
    target = np.array([0.0, 0.0, 900.0])
    for i in range(n):
        a = 2 * np.pi * i / n
        c = np.array([radius_mm * np.cos(a), radius_mm * np.sin(a), 1500.0])
        z = (target - c) / np.linalg.norm(target - c)
        x = np.cross(z, [0, 0, 1.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        rot = np.stack([x, y, z])
        k = np.array([[1100.0 + 20 * i, 0, 640], [0, 1100.0 + 20 * i, 400], [0, 0, 1.0]])
        cams.append(Camera(f"cam{i}", (1280, 800), k, np.array(dist), matrix_to_rodrigues(rot), -rot @ c))
    return Rig(tuple(cams))


def _walk(t_frames: int, fps: float = 30.0, seed: int = 0, rigid: bool = False) -> np.ndarray:
    """(T, 26, 3) mm: a halpe26-like point cloud moving smoothly (ground truth). ``rigid``: one rigid
    body turning about the vertical (constant limb lengths); else every joint also wobbles at 1 Hz."""
    rng = np.random.default_rng(seed)
    t = np.arange(t_frames) / fps
    base = rng.normal(0, 250, (26, 3))
    path = np.stack([300 * np.sin(0.6 * t), 200 * np.cos(0.4 * t), 900 + 30 * np.sin(2 * t)], -1)
    if rigid:
        a = 0.8 * np.sin(1.3 * t)
        rot = np.zeros((t_frames, 3, 3))
        rot[:, 0, 0], rot[:, 0, 1], rot[:, 1, 0], rot[:, 1, 1], rot[:, 2, 2] = np.cos(a), -np.sin(a), np.sin(a), np.cos(a), 1
        return np.einsum("tij,kj->tki", rot, base) + path[:, None]
    wobble = 40 * np.sin(2 * np.pi * 1.0 * t[:, None, None] + rng.uniform(0, 6, (1, 26, 3)))
    return base[None] + path[:, None] + wobble


def _detect(rig: Rig, points_mm: np.ndarray, *, noise_px: float, outliers: float, seed: int = 0):
    rng = np.random.default_rng(seed)
    px = rig.project(points_mm)
    kp = np.concatenate([px + rng.normal(0, noise_px, px.shape), rng.uniform(0.6, 1.0, px.shape[:-1] + (1,))], -1)
    bad = rng.random(px.shape[:-1]) < outliers
    kp[bad, :2] += rng.uniform(80, 300, (bad.sum(), 2)) * rng.choice([-1, 1], (bad.sum(), 2))
    return kp


@pytest.fixture
def ring_rig():
    return _ring_rig


@pytest.fixture
def scene():
    """Factory: (rig, detections, ground truth (T, 26, 3) mm)."""

    def make(*, cameras=6, frames=30, noise_px=1.0, outliers=0.0, seed=0, fps=30.0, rigid=False):
        rig = _ring_rig(cameras)
        gt = _walk(frames, fps, seed, rigid)
        kp = _detect(rig, gt, noise_px=noise_px, outliers=outliers, seed=seed)
        det = MultiViewKeypoints.of_one_person(kp, rig.names, np.arange(frames) / fps, get_skeleton("halpe26"))
        return rig, det, gt

    return make
