"""A small hand-made multi-person scene for association unit tests (independent of the synthetic world)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pytest
from gaitcap.reconstruction.camera import Camera, Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import get_skeleton

# Stick-figure offsets (mm) of the Halpe-26 joints from the pelvis: x forward, y left, z up.
_OFFSETS = {
    "nose": (80, 0, 700), "left_eye": (70, 30, 730), "right_eye": (70, -30, 730),
    "left_ear": (0, 70, 710), "right_ear": (0, -70, 710), "left_shoulder": (0, 180, 500),
    "right_shoulder": (0, -180, 500), "left_elbow": (0, 200, 220), "right_elbow": (0, -200, 220),
    "left_wrist": (30, 210, -20), "right_wrist": (30, -210, -20), "left_hip": (0, 100, 0),
    "right_hip": (0, -100, 0), "left_knee": (0, 100, -450), "right_knee": (0, -100, -450),
    "left_ankle": (0, 100, -880), "right_ankle": (0, -100, -880), "head": (0, 0, 800),
    "neck": (0, 0, 560), "pelvis": (0, 0, 0), "left_big_toe": (180, 110, -950),
    "right_big_toe": (180, -110, -950), "left_small_toe": (160, 140, -950),
    "right_small_toe": (160, -140, -950), "left_heel": (-50, 100, -950), "right_heel": (-50, -100, -950),
}


def make_rig(num_cameras: int = 8, radius_mm: float = 5000.0, size_px=(1280, 1024)) -> Rig:
    """Cameras on an ellipse around a walkway along x, all looking at the centre from 1.8 m height."""
    cams = []
    for i in range(num_cameras):
        a = 2 * np.pi * i / num_cameras + 0.2
        center = np.array([1.3 * radius_mm * np.cos(a), radius_mm * np.sin(a), 1800.0])
        target = np.array([0.0, 0.0, 900.0])
        z = target - center
        z /= np.linalg.norm(z)
        x = np.cross(z, [0, 0, 1.0])
        x /= np.linalg.norm(x)
        y = np.cross(z, x)
        rot = np.stack([x, y, z])
        from gaitcap.reconstruction.camera import matrix_to_rodrigues

        k = np.array([[1100.0, 0, size_px[0] / 2], [0, 1100.0, size_px[1] / 2], [0, 0, 1]])
        cams.append(Camera(f"cam{i}", size_px, k, dist=np.array([-0.05, 0, 0, 0, 0]),
                           rvec=matrix_to_rodrigues(rot), tvec_mm=-rot @ center))
    return Rig(tuple(cams))


def person_points(root_xy_mm: np.ndarray, heading: np.ndarray, phase: np.ndarray) -> np.ndarray:
    """(T, J, 3) mm: the stick figure at root positions (T, 2), heading angle (T,), gait phase (T,)."""
    skel = get_skeleton("halpe26")
    off = np.array([_OFFSETS[n] for n in skel.joint_names], float)  # (J, 3)
    t_ = len(root_xy_mm)
    pts = np.broadcast_to(off, (t_, *off.shape)).copy()
    swing = 250 * np.sin(phase)
    for side, sign in (("left", 1), ("right", -1)):
        for j in ("knee", "ankle", "big_toe", "small_toe", "heel"):
            idx = skel.index(f"{side}_{j}")
            pts[:, idx, 0] += sign * swing * (0.5 if j == "knee" else 1.0)
    c, s = np.cos(heading)[:, None], np.sin(heading)[:, None]
    x, y = pts[..., 0] * c - pts[..., 1] * s, pts[..., 0] * s + pts[..., 1] * c
    return np.stack([x + root_xy_mm[:, :1], y + root_xy_mm[:, 1:], pts[..., 2] + 950.0], -1)


@dataclass
class Scene:
    rig: Rig
    multi: MultiViewKeypoints
    identity: np.ndarray  # (C, T, P) ground-truth person id, -1 empty
    points_mm: np.ndarray  # (people, T, J, 3)


def make_scene(*, frames=60, people=3, num_cameras=8, noise_px=1.5, seed=0, fps=30.0, drop=0.0,
               beside_mm=650.0, crossing=False) -> Scene:
    """Patient (id 0) walks along x; a therapist walks beside at y = ``beside_mm``; a third person
    stands (or, with ``crossing``, walks across the walkway and back)."""
    rng = np.random.default_rng(seed)
    t = np.arange(frames) / fps
    leg = 4500.0 / 1200.0  # s per pass along the walkway at 1.2 m/s, then turn and walk back
    phase = (t / leg) % 2
    x = -2250 + 4500 * np.where(phase < 1, phase, 2 - phase)
    heading = np.where(phase < 1, 0.0, np.pi)
    tracks = [person_points(np.stack([x, np.zeros_like(x)], -1), heading, 2 * np.pi * t)]
    if people >= 2:
        tracks.append(person_points(np.stack([x - 150, np.full_like(x, 650)], -1), heading,
                                    2 * np.pi * t + 1))
    if people >= 2:
        tracks[1] = person_points(np.stack([x - 150, np.full_like(x, beside_mm)], -1), heading,
                                  2 * np.pi * t + 1)
    if people >= 3 and crossing:
        y = 2500 * np.cos(2 * np.pi * t / 6)
        tracks.append(person_points(np.stack([np.full_like(y, 300), y], -1),
                                    np.where(np.sin(2 * np.pi * t / 6) > 0, -np.pi / 2, np.pi / 2),
                                    2 * np.pi * t))
    elif people >= 3:
        tracks.append(person_points(np.tile([800.0, -1800.0], (frames, 1)), np.full(frames, 1.0),
                                    np.zeros(frames)))
    pts = np.stack(tracks)  # (people, T, J, 3)
    rig = make_rig(num_cameras)
    proj = rig.project(pts)  # (C, people, T, J, 2)
    c_, n_, t_, j_, _ = proj.shape
    kp = np.concatenate([proj + rng.normal(0, noise_px, proj.shape), np.full((*proj.shape[:-1], 1), 0.9)],
                        -1).transpose(0, 2, 1, 3, 4)  # (C, T, people, J, 3)
    ident = np.broadcast_to(np.arange(n_), (c_, t_, n_)).copy()
    gone = rng.random((c_, t_, n_)) < drop
    kp[gone] = np.nan
    ident[gone] = -1
    order = np.argsort(rng.random((c_, t_, n_)), axis=-1)
    kp = np.take_along_axis(kp, order[..., None, None], 2)
    ident = np.take_along_axis(ident, order, 2)
    multi = MultiViewKeypoints(kp, rig.names, t, "halpe26")
    return Scene(rig=rig, multi=multi, identity=ident, points_mm=pts)


@pytest.fixture(scope="session")
def scene3() -> Scene:
    return make_scene(frames=60, people=3, seed=1, drop=0.05)


@pytest.fixture(scope="session")
def crossing_scene() -> Scene:
    """A therapist close beside the patient (450 mm) and a third person crossing the walkway."""
    return make_scene(frames=180, people=3, seed=5, crossing=True, beside_mm=450, noise_px=4, drop=0.15)


@pytest.fixture(scope="session")
def six_scene() -> Scene:
    """Six people walking circles around the room (the paper's lab had up to six in view)."""
    rng = np.random.default_rng(6)
    t = np.arange(60) / 30
    people = []
    for i in range(6):
        a = 2 * np.pi * i / 6
        xy = 2200 * np.array([np.cos(a), np.sin(a)]) + np.stack(
            [600 * np.cos(0.5 * t + i), 600 * np.sin(0.5 * t + i)], -1)
        people.append(person_points(xy, 0.5 * t + i + np.pi / 2, 2 * np.pi * t))
    pts = np.stack(people)
    rig = make_rig(10)
    proj = rig.project(pts)
    kp = np.concatenate([proj + rng.normal(0, 2, proj.shape), np.full((*proj.shape[:-1], 1), 0.9)],
                        -1).transpose(0, 2, 1, 3, 4)
    c_, t_, n_ = kp.shape[:3]
    ident = np.broadcast_to(np.arange(n_), (c_, t_, n_)).copy()
    order = np.argsort(rng.random((c_, t_, n_)), axis=-1)
    kp = np.take_along_axis(kp, order[..., None, None], 2)
    ident = np.take_along_axis(ident, order, 2)
    return Scene(rig=rig, multi=MultiViewKeypoints(kp, rig.names, t, "halpe26"), identity=ident,
                 points_mm=pts)
