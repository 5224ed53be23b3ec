"""Real motion-capture walks with annotated gait events, seen by the simulated rig.

Data: the example walks of the gaitkit sdist (MIT), installed by ``deploy/bootstrap.sh`` into
``$VENV/share/gaitcap/testdata/gait-mocap/`` (never downloaded at run time):
- ``example_healthy.json``: a healthy adult walking overground, 150 Hz, from Fukuchi, Fukuchi & Duarte
  (2018) "A public dataset of overground and treadmill walking kinematics and kinetics in healthy
  individuals", PeerJ 6:e4640 (CC-BY 4.0); events from the force plates / annotation.
- ``example_parkinson.json``: a person with Parkinson's disease walking overground, 150 Hz (ODC-By 1.0).
Each holds heel, toe, ankle, knee and hip marker trajectories (mm, y up), shoulders in one, and the
annotated heel strikes and toe offs (frame numbers per foot).

Annotations are screened before use, by physical rules that do not depend on any event detector: at a
heel strike heel or toe, at a toe off the toe, is within ``MAX_CONTACT_HEIGHT_MM`` of its lowest height
in the trial (it touches the floor); a foot's events of one kind are at least ``MIN_STRIDE_S`` apart; a
toe off comes at least ``MIN_STANCE_S`` after that foot's heel strike, a heel strike at least
``MIN_SWING_S`` after its toe off (walking stances and swings are longer). Excluded annotations are
kept with the reason (``MocapWalk.excluded``); the healthy example's toe offs mostly fail (two in one
stance, toe 70-80 mm off the floor).

``rig_view`` places the walk on the room's diagonal (z up, floor at 0), resamples it to the rig's frame
rate (every k-th mocap frame from ``phase``), completes the Halpe-26 joints the markers lack (head,
arms, toes' sides) rigidly from the trunk, and simulates the detector on the rig (``noise.detect``).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.acquisition.installed import share_path
from gaitcap.reconstruction.camera import Rig
from gaitcap.reconstruction.keypoints import MultiViewKeypoints
from gaitcap.reconstruction.skeletons import get_skeleton
from gaitcap.simulator.noise import detect, get_preset
from gaitcap.simulator.path import Room
from gaitcap.simulator.room import build_rig

MOCAP_DIR = share_path("testdata", "gait-mocap")
MOCAP_WALKS = {"healthy": "example_healthy.json", "parkinson": "example_parkinson.json"}
MIN_STANCE_S = 0.4
MIN_SWING_S = 0.25
MIN_STRIDE_S = 0.6
MAX_CONTACT_HEIGHT_MM = 30.0
SIDES = ("left", "right")
_MARKERS = ("hip", "knee", "ankle", "heel", "toe")
SKELETON = get_skeleton("halpe26")


@dataclass(frozen=True, eq=False)
class MocapWalk:
    """One real walk (room frame: mm, z up, floor z = 0, walking along +x from x = 0).

    Attributes:
        name, source: dataset name and citation/licence line.
        rate_hz: marker rate (Hz).
        times_s: (T,) marker times (s, from 0).
        markers_mm: name -> (T, 3) for ``{side}_{hip,knee,ankle,heel,toe}``, shoulders and
            ``{side}_small_toe`` when given.
        heel_strike_s, toe_off_s: foot -> (K,) screened annotated events (s).
        excluded: (event, foot, time s, reason) of annotations that failed the screening.
    """

    name: str
    source: str
    rate_hz: float
    times_s: np.ndarray
    markers_mm: dict[str, np.ndarray]
    heel_strike_s: dict[str, np.ndarray]
    toe_off_s: dict[str, np.ndarray]
    excluded: tuple[tuple[str, str, float, str], ...]

    @property
    def duration_s(self) -> float:
        return float(self.times_s[-1] - self.times_s[0])


def available_walks(directory: Path = MOCAP_DIR) -> list[str]:
    """Names of the installed walks (empty when bootstrap has not installed them)."""
    return [name for name, file in MOCAP_WALKS.items() if (directory / file).is_file()]


def _to_room(raw: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Mocap axes (y up) -> room axes: z up, progression along +x, floor (lowest foot marker) at 0."""
    hips = 0.5 * (raw["left_hip"] + raw["right_hip"])
    feet = np.concatenate([raw[f"{s}_{m}"] for s in SIDES for m in ("heel", "toe")])
    up = int(np.argmax(hips.mean(axis=0) - feet.mean(axis=0)))
    horizontal = [a for a in range(3) if a != up]
    travel = hips[-1, horizontal] - hips[0, horizontal]
    heading = math.atan2(travel[1], travel[0])
    c, s = math.cos(-heading), math.sin(-heading)
    floor = float(np.min(feet[:, up]))
    start = hips[0, horizontal]
    out = {}
    for name, p in raw.items():
        xy = p[:, horizontal] - start
        z = p[:, up] - floor
        x, y = c * xy[:, 0] - s * xy[:, 1], s * xy[:, 0] + c * xy[:, 1]
        # a left-handed mocap frame would mirror the walker: keep left on the left of progression
        out[name] = np.stack([x, y, z], axis=1)
    lat = np.mean(out["left_hip"][:, 1] - out["right_hip"][:, 1])
    if lat < 0:
        for p in out.values():
            p[:, 1] *= -1.0
    return out


def _screen(markers: dict[str, np.ndarray], times_s: np.ndarray, events: dict[str, dict[str, list[float]]]):
    """Screened (heel strikes, toe offs, excluded) per the module docstring."""
    kept = {"heel_strike": {}, "toe_off": {}}
    excluded = []
    for side in SIDES:
        lift = {m: markers[f"{side}_{m}"][:, 2] - np.min(markers[f"{side}_{m}"][:, 2]) for m in ("heel", "toe")}
        # first contact: heel or toe on the floor; last contact: the toe
        touching = {"heel_strike": np.minimum(lift["heel"], lift["toe"]), "toe_off": lift["toe"]}
        seq = sorted([(t, "heel_strike") for t in events["heel_strike"][side]]
                     + [(t, "toe_off") for t in events["toe_off"][side]])
        ok: list[tuple[float, str]] = []
        for t, kind in seq:
            z = float(np.interp(t, times_s, touching[kind]))
            same = [u for u, k in ok if k == kind]
            gap = t - ok[-1][0] if ok else np.inf
            least = MIN_STANCE_S if kind == "toe_off" else MIN_SWING_S
            if z > MAX_CONTACT_HEIGHT_MM:
                excluded.append((kind, side, t, f"foot {z:.0f} mm above the floor"))
            elif same and t - same[-1] < MIN_STRIDE_S:
                excluded.append((kind, side, t, f"{t - same[-1]:.2f} s after the previous {kind}"))
            elif ok and ok[-1][1] != kind and gap < least:
                excluded.append((kind, side, t, f"only {gap:.2f} s after the {ok[-1][1]}"))
            else:
                ok.append((t, kind))
        for kind in kept:
            kept[kind][side] = np.array([t for t, k in ok if k == kind])
    return kept["heel_strike"], kept["toe_off"], tuple(excluded)


def load_walk(name: str, directory: Path = MOCAP_DIR) -> MocapWalk:
    """Load an installed walk by name (``MOCAP_WALKS``); FileNotFoundError naming bootstrap if absent."""
    if name not in MOCAP_WALKS:
        raise ValueError(f"walk: unknown name {name!r}, expected one of {sorted(MOCAP_WALKS)}")
    path = directory / MOCAP_WALKS[name]
    if not path.is_file():
        raise FileNotFoundError(f"{path} is missing: run deploy/bootstrap.sh (install_gait_mocap)")
    data = json.loads(path.read_text())
    rate = float(data["fps"])
    frames = data["angle_frames"]
    names = [f"{s}_{m}" for s in SIDES for m in _MARKERS] + ["left_shoulder", "right_shoulder"]
    raw = {n: np.array([f["landmark_positions"][n] for f in frames], dtype=np.float64) for n in names}
    if not (np.any(raw["left_shoulder"]) and np.any(raw["right_shoulder"])):
        raw.pop("left_shoulder"), raw.pop("right_shoulder")
    for n, p in raw.items():
        if p.shape != (len(frames), 3) or not np.isfinite(p).all():
            raise ValueError(f"{path.name}: marker {n} is not a finite (T, 3) trajectory")
    times = np.arange(len(frames)) / rate
    markers = _to_room(raw)
    truth = data["ground_truth"]
    events = {kind: {s: [f / rate for f in truth[f"{key}_frames"][s]] for s in SIDES}
              for kind, key in (("heel_strike", "hs"), ("toe_off", "to"))}
    hs, to, excluded = _screen(markers, times, events)
    return MocapWalk(str(data["name"]), str(data["source"]), rate, times, markers, hs, to, excluded)


def halpe26_points(walk: MocapWalk) -> np.ndarray:
    """(T, 26, 3) Halpe-26 joints (mm): the markers where they exist, the rest placed rigidly from the
    pelvis and the walking direction (trunk 0.29 m/m of hip height, upright; arms hanging)."""
    m = walk.markers_mm
    t_len = len(walk.times_s)
    out = np.zeros((t_len, 26, 3))
    j = SKELETON.index
    for side in SIDES:
        for marker, joint in (("hip", "hip"), ("knee", "knee"), ("ankle", "ankle"), ("heel", "heel"),
                              ("toe", "big_toe")):
            out[:, j(f"{side}_{joint}")] = m[f"{side}_{marker}"]
    pelvis = 0.5 * (m["left_hip"] + m["right_hip"])
    out[:, j("pelvis")] = pelvis
    hip_height = float(np.median(pelvis[:, 2]))
    lateral = m["left_hip"] - m["right_hip"]
    lateral[:, 2] = 0.0
    lateral /= np.linalg.norm(lateral, axis=1, keepdims=True)
    fwd = np.stack([lateral[:, 1], -lateral[:, 0], np.zeros(t_len)], axis=1)
    up = np.array([0.0, 0.0, 1.0])
    if "left_shoulder" in m:
        shoulders = {s: m[f"{s}_shoulder"] for s in SIDES}
    else:
        neck0 = pelvis + 0.55 * hip_height * up
        shoulders = {s: neck0 + sign * 0.2 * hip_height * lateral - 0.04 * hip_height * up
                     for s, sign in (("left", 1.0), ("right", -1.0))}
    neck = 0.5 * (shoulders["left"] + shoulders["right"]) + 0.04 * hip_height * up
    out[:, j("neck")] = neck
    for s, sign in (("left", 1.0), ("right", -1.0)):
        out[:, j(f"{s}_shoulder")] = shoulders[s]
        out[:, j(f"{s}_elbow")] = shoulders[s] - 0.33 * hip_height * up + 0.03 * hip_height * sign * lateral
        out[:, j(f"{s}_wrist")] = out[:, j(f"{s}_elbow")] - 0.27 * hip_height * up + 0.05 * hip_height * fwd
        out[:, j(f"{s}_ear")] = neck + 0.16 * hip_height * up + sign * 0.08 * hip_height * lateral
        out[:, j(f"{s}_eye")] = neck + 0.18 * hip_height * up + sign * 0.035 * hip_height * lateral \
            + 0.09 * hip_height * fwd
        if f"{s}_small_toe" in m:  # a walk that places its small toe in the foot's own frame (pig_walks)
            out[:, j(f"{s}_small_toe")] = m[f"{s}_small_toe"]
        else:
            foot = m[f"{s}_toe"] - m[f"{s}_heel"]
            out[:, j(f"{s}_small_toe")] = m[f"{s}_heel"] + 0.8 * foot + sign * 0.05 * hip_height * lateral
    out[:, j("nose")] = neck + 0.14 * hip_height * up + 0.11 * hip_height * fwd
    out[:, j("head")] = neck + 0.3 * hip_height * up
    return out


@dataclass(frozen=True, eq=False)
class RigView:
    """A real walk as the rig sees it: (T,) frame times (s), (T, 26, 3) joints (mm, room frame), the
    simulated detections and the rig."""

    times_s: np.ndarray
    points_mm: np.ndarray
    detections: MultiViewKeypoints
    rig: Rig


def rig_view(walk: MocapWalk, *, fps: float = 30.0, phase: int = 0, preset: str = "paper", cameras: int = 10,
             seed: int = 0) -> RigView:
    """The walk on the room's diagonal, sampled at ``fps`` from mocap frame ``phase`` (event times stay on
    the walk's clock: frame k is at ``phase / rate_hz + k / fps`` s), detected with noise ``preset``."""
    step = walk.rate_hz / fps
    if abs(step - round(step)) > 1e-6 or step < 1:
        raise ValueError(f"fps: {fps} must divide the walk's {walk.rate_hz} Hz")
    if not 0 <= phase < round(step):
        raise ValueError(f"phase: must be in [0, {round(step) - 1}], got {phase}")
    idx = np.arange(phase, len(walk.times_s), int(round(step)))
    points = halpe26_points(walk)[idx]
    room = Room()
    d = (room.corner_b - room.corner_a) / room.diagonal_mm
    rot = np.array([[d[0], -d[1], 0.0], [d[1], d[0], 0.0], [0.0, 0.0, 1.0]])
    travel = float(points[-1, SKELETON.index("pelvis"), 0])
    points = (points - np.array([0.5 * travel, 0.0, 0.0])) @ rot.T
    times = walk.times_s[idx]
    detections, rig = film_points(points, times, preset=preset, cameras=cameras, seed=seed,
                                  rng=np.random.default_rng([seed, 31, phase]), room=room)
    return RigView(times, points, detections, rig)


def film_points(points_mm: np.ndarray, times_s: np.ndarray, *, preset: str, cameras: int, seed: int,
                rng: np.random.Generator, room: Room | None = None) -> tuple[MultiViewKeypoints, Rig]:
    """Halpe-26 joints (T, 26, 3) mm at (T,) s, room frame, seen by the room's ``cameras``-camera rig
    (``seed``) through the simulated detector with noise ``preset``: (detections, rig)."""
    rig = build_rig(cameras, seed=seed, room=room or Room())
    velocity = np.gradient(points_mm, times_s, axis=0)
    height = 1.0 / 0.53 * float(np.median(points_mm[:, SKELETON.index("pelvis"), 2]))
    keypoints = detect(rig, points_mm, velocity, height, get_preset(preset), np.zeros((len(rig), len(times_s))),
                       rng)
    return MultiViewKeypoints.of_one_person(keypoints, tuple(rig.names), times_s, SKELETON), rig


def rig_phases(walk: MocapWalk, fps: float = 30.0) -> int:
    """How many sampling phases ``rig_view`` offers for this walk at ``fps`` (its rate / fps)."""
    return int(round(walk.rate_hz / fps))
