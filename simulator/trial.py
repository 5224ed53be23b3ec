"""``make_trial``: one synthetic recording with ground truth (patient, cameras, detections, gait truth)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints, missing_keypoints
from gaitcap.reconstruction.skeletons import Skeleton, get_skeleton
from gaitcap.simulator.glitch import FootGlitch, glitched_points
from gaitcap.simulator.noise import NoisePreset, clock_model, detect, get_preset, occlusion_mask
from gaitcap.simulator.params import WalkParams
from gaitcap.simulator.path import FootPlan, Room, plan_walk
from gaitcap.simulator.people import bystander, therapist
from gaitcap.simulator.room import build_rig
from gaitcap.simulator.truth import GaitTruth, gait_truth
from gaitcap.simulator.walker import Body, simulate_body

MIN_SECONDS = 4.0
MAX_PEOPLE = 3


@dataclass(frozen=True, eq=False)
class SyntheticPeople:
    """Everyone's detections per camera, in arbitrary per-frame slot order (like a real detector), with the
    ground truth of who is who.

    observed: what the detector reports, (C, T, P, J, 3) x px, y px, confidence (empty slots NaN / 0):
        association's input.
    identity: (C, T, P) int, ground-truth person of each slot (-1 = empty); person 0 is the patient.
    points_mm: (P, T, J, 3) ground truth of every person.
    """

    observed: MultiViewKeypoints
    identity: np.ndarray
    points_mm: np.ndarray

    def person(self, p: int) -> np.ndarray:
        """(C, T, J, 3) detections of person ``p`` gathered from the slots (NaN / 0 where not detected)."""
        kp = self.observed.keypoints
        out = missing_keypoints((*kp.shape[:2], kp.shape[3]))
        ci, ti, si = np.nonzero(self.identity == p)
        out[ci, ti] = kp[ci, ti, si]
        return out


@dataclass(frozen=True, eq=False)
class SyntheticTrial:
    """A synthetic trial (see the package docstring for the conventions)."""

    preset: NoisePreset
    seed: int
    fps: float
    rig: Rig
    skeleton: Skeleton
    times_s: np.ndarray  # (T,)
    points_mm: np.ndarray  # (T, J, 3) patient ground truth
    detections: MultiViewKeypoints  # patient, (C, T, 1, J, 3)
    truth: GaitTruth
    params: WalkParams
    body: Body
    plan: FootPlan
    multi: SyntheticPeople | None
    clock_offsets_ns: np.ndarray  # (C,) int64
    jitter_ns: np.ndarray  # (C, T) int64
    room: Room

    @property
    def num_frames(self) -> int:
        return int(self.times_s.shape[0])

    def everyone(self) -> MultiViewKeypoints:
        """Every person's detections as a detector reports them: :attr:`multi`'s, or the patient alone."""
        if self.multi is not None:
            return self.multi.observed
        return self.detections

    @property
    def all_points_mm(self) -> np.ndarray:
        """(P, T, J, 3): every person's ground truth (patient first)."""
        return self.multi.points_mm if self.multi is not None else self.points_mm[None]


def _velocity(points: np.ndarray, times: np.ndarray) -> np.ndarray:
    if points.shape[0] < 2:
        return np.zeros_like(points)
    return np.gradient(points, times, axis=0)


def make_trial(
    preset: str | NoisePreset = "paper",
    seconds: float = 30.0,
    cameras: int = 10,
    people: int = 1,
    seed: int = 0,
    fps: float = 30.0,
    walk: WalkParams | None = None,
    glitch: FootGlitch | None = None,
) -> SyntheticTrial:
    """Simulate a trial: the patient walking the room's diagonal, seen by ``cameras`` cameras.

    Deterministic given the arguments. ``people`` = 2 adds a therapist walking beside the patient, 3 also a
    person standing in the room. ``glitch``: the detector misplaces one footfall of the patient in every
    camera (:class:`~gaitcap.simulator.glitch.FootGlitch`: one impossible step; the truth is the real walk).
    Raises ValueError with a clear message on bad arguments.
    """
    noise = get_preset(preset)
    if not isinstance(seconds, int | float) or not math.isfinite(seconds) or seconds < MIN_SECONDS:
        raise ValueError(f"seconds must be >= {MIN_SECONDS:g}, got {seconds}")
    if seconds > 600:
        raise ValueError(f"seconds must be <= 600, got {seconds}")
    if isinstance(cameras, bool) or int(cameras) != cameras or cameras < 2:
        raise ValueError(f"cameras must be an integer >= 2, got {cameras}")
    if isinstance(people, bool) or int(people) != people or not 1 <= people <= MAX_PEOPLE:
        raise ValueError(f"people must be 1, 2 or 3, got {people}")
    if not math.isfinite(fps) or not 5.0 <= fps <= 240.0:
        raise ValueError(f"fps must be in [5, 240], got {fps}")
    if walk is not None and not isinstance(walk, WalkParams):
        raise ValueError(f"walk must be a WalkParams or None, got {type(walk).__name__}")
    if glitch is not None and not isinstance(glitch, FootGlitch):
        raise ValueError(f"glitch must be a FootGlitch or None, got {type(glitch).__name__}")
    seed = int(seed)
    params = walk or WalkParams()
    room = Room()
    n_frames = int(round(seconds * fps))
    times = np.arange(n_frames) / fps
    plan = plan_walk(params, seconds, room, seed=seed)
    body = Body.from_params(params)
    points = simulate_body(plan, params, times, body)
    truth = gait_truth(plan, body, duration_s=float(times[-1]))
    rig = build_rig(int(cameras), seed=seed, room=room, walkway_margin_mm=params.walkway_margin_mm)
    skel = get_skeleton("halpe26")

    rng_people = np.random.default_rng([seed, 11])
    everyone = [points]
    heights = [body.height]
    if people >= 2:
        tp, _, tpts = therapist(rng_people, params, points, times, room)
        everyone.append(tpts)
        heights.append(Body.from_params(tp).height)
    if people >= 3:
        bp, _, bpts = bystander(rng_people, times)
        everyone.append(bpts)
        heights.append(Body.from_params(bp).height)
    all_pts = np.stack(everyone)
    heights = np.array(heights)
    seen = all_pts.copy()  # what the detector makes of everyone (the patient's glitched footfall)
    if glitch is not None:
        seen[0] = glitched_points(points, times, skel, glitch, truth)

    rng_clock = np.random.default_rng([seed, 23])
    offsets_ns, jitter_ns = clock_model(noise, len(rig), n_frames, rng_clock)
    dt = (offsets_ns[:, None] + jitter_ns) * 1e-9
    per_person = []
    for p in range(len(everyone)):
        rng_det = np.random.default_rng([seed, 31, p])
        occ = occlusion_mask(rig, all_pts, heights, p) if noise.occlusion else None
        others = np.delete(all_pts, p, axis=0) if len(everyone) > 1 else None
        kp = detect(rig, seen[p], _velocity(seen[p], times), heights[p], noise, dt, rng_det, occ, others)
        per_person.append(kp)
    detections = MultiViewKeypoints.of_one_person(per_person[0], tuple(rig.names), times, skel)

    multi = None
    if people > 1:
        rng_slots = np.random.default_rng([seed, 47])
        n_p = len(everyone)
        c_len = len(rig)
        stacked = np.stack(per_person, axis=2)  # (C, T, P, J, 3)
        detected = np.isfinite(stacked[..., 0]).any(-1)  # (C, T, P)
        keypoints = np.full_like(stacked, np.nan)
        keypoints[..., 2] = 0.0
        identity = np.full((c_len, n_frames, n_p), -1, dtype=np.int64)
        # random slot order per camera and frame; detected people first, empty slots last
        keys = rng_slots.random((c_len, n_frames, n_p)) + np.where(detected, 0.0, 2.0)
        order = np.argsort(keys, axis=-1)
        ci, ti = np.meshgrid(np.arange(c_len), np.arange(n_frames), indexing="ij")
        for slot in range(n_p):
            who = order[..., slot]
            det = detected[ci, ti, who]
            keypoints[:, :, slot] = np.where(det[..., None, None], stacked[ci, ti, who], keypoints[:, :, slot])
            identity[:, :, slot] = np.where(det, who, -1)
        multi = SyntheticPeople(MultiViewKeypoints(keypoints, tuple(rig.names), times, skel), identity, all_pts)

    return SyntheticTrial(
        preset=noise, seed=seed, fps=float(fps), rig=rig, skeleton=skel, times_s=times, points_mm=points,
        detections=detections, truth=truth, params=params, body=body, plan=plan, multi=multi,
        clock_offsets_ns=offsets_ns, jitter_ns=jitter_ns, room=room,
    )
