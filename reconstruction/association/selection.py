"""Choosing the patient among the tracks, and handing the chosen person's detections to reconstruction.

Selectors are small frozen classes with ``choose(tracks) -> track id``:

- :class:`WalkwayTrack` (automatic): the person who walks the walkway, i.e. who covers the most distance
  along the walkway axis near its centre line (each step weighted by a Gaussian of the distance from
  the line, so someone walking beside the patient scores less). The walkway is given by two floor points or, when
  not given, runs along the main direction of motion through a given point (by default the centre of
  the camera rig, which surrounds the walkway).
- :class:`NearestStartTrack` (automatic): the person who comes nearest a configured start position early
  in their track.
- :class:`ManualTrack`: a track id chosen by the clinician (see :func:`select_track_at_pixel` for a click
  on a camera preview).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from gaitcap.reconstruction.association.tracking import Tracks
from gaitcap.reconstruction.keypoints import MultiViewKeypoints


class TrackSelector(Protocol):
    def choose(self, tracks: Tracks) -> int: ...


def _require_tracks(tracks: Tracks) -> None:
    if tracks.num_tracks == 0:
        raise ValueError("no person was tracked in this trial: nothing to select")


def _floor(points_mm: np.ndarray, up_axis: int) -> np.ndarray:
    """(..., 3) -> (..., 2) coordinates in the floor plane."""
    return np.delete(points_mm, up_axis, axis=-1)


@dataclass(frozen=True)
class ManualTrack:
    """A track chosen by id."""

    track_id: int

    def choose(self, tracks: Tracks) -> int:
        return tracks.check_id(self.track_id)


@dataclass(frozen=True)
class WalkwayTrack:
    """The person who walks the walkway.

    Attributes:
        start_mm, end_mm: two points (x, y, z mm) on the walkway's centre line; None: estimated (the main
            direction of all tracks' motion, through ``through_mm``).
        through_mm: a point on the centre line when the ends are not given (None: the tracks' mean).
        corridor_half_width_mm: walking this far from the centre line counts e^-2 (13 %) as much as on
            the line (Gaussian weight with sigma = half the corridor width).
        up_axis: index of the vertical world axis (the floor is the other two).
        smoothing_s: progress is measured over windows this long, so the jitter of a track's root
            (which shifts with the joints seen) does not count as walking.
    """

    start_mm: tuple[float, float, float] | None = None
    end_mm: tuple[float, float, float] | None = None
    through_mm: tuple[float, float, float] | None = None
    corridor_half_width_mm: float = 500.0
    up_axis: int = 2
    smoothing_s: float = 1.0

    def __post_init__(self) -> None:
        if not self.smoothing_s > 0:
            raise ValueError("WalkwayTrack.smoothing_s must be > 0")
        if (self.start_mm is None) != (self.end_mm is None):
            raise ValueError("WalkwayTrack: give both start_mm and end_mm, or neither")
        if not self.corridor_half_width_mm > 0:
            raise ValueError("WalkwayTrack.corridor_half_width_mm must be > 0")
        if self.up_axis not in (0, 1, 2):
            raise ValueError(f"WalkwayTrack.up_axis must be 0, 1 or 2, got {self.up_axis}")

    def line(self, tracks: Tracks) -> tuple[np.ndarray, np.ndarray]:
        """The walkway centre line in the floor plane: a point (2,) and a unit direction (2,)."""
        if self.start_mm is not None:
            a, b = (_floor(np.asarray(p, float), self.up_axis) for p in (self.start_mm, self.end_mm))
            if np.linalg.norm(b - a) < 1.0:
                raise ValueError("WalkwayTrack: start_mm and end_mm must differ")
            return a, (b - a) / np.linalg.norm(b - a)
        floor = _floor(tracks.root_mm, self.up_axis)  # (M, T, 2)
        lag = self._lag(tracks)
        steps = (floor[:, lag:] - floor[:, :-lag]).reshape(-1, 2) if floor.shape[1] > lag else np.empty((0, 2))
        steps = steps[np.isfinite(steps).all(-1)]
        if len(steps) == 0:
            direction = np.array([1.0, 0.0])
        else:
            _, _, vt = np.linalg.svd(steps.T @ steps)
            direction = vt[0]
        if self.through_mm is not None:
            origin = _floor(np.asarray(self.through_mm, float), self.up_axis)
        else:
            origin = np.nanmean(floor.reshape(-1, 2), axis=0)
        return origin, direction

    def scores(self, tracks: Tracks) -> np.ndarray:
        """(M,) distance (mm) each track covers along the walkway, weighted by nearness to its line."""
        _require_tracks(tracks)
        origin, direction = self.line(tracks)
        rel = _floor(tracks.root_mm, self.up_axis) - origin  # (M, T, 2)
        along = rel @ direction
        lateral = np.abs(rel[..., 0] * direction[1] - rel[..., 1] * direction[0])
        out = np.zeros(tracks.num_tracks)
        sigma = self.corridor_half_width_mm / 2
        lag = self._lag(tracks)
        for m in range(tracks.num_tracks):
            a, lat = along[m], lateral[m]
            if a.size <= lag:
                continue
            # progress over windows of `lag` frames (jitter of the root averages out), per frame
            moved = np.abs(a[lag:] - a[:-lag]) / lag
            weight = np.exp(-0.5 * (np.maximum(lat[lag:], lat[:-lag]) / sigma) ** 2)
            out[m] = np.nansum(moved * weight)
        return out

    def _lag(self, tracks: Tracks) -> int:
        """Frames per ``smoothing_s`` (at least 1)."""
        if tracks.times_s.size < 2:
            return 1
        dt = float(np.median(np.diff(tracks.times_s)))
        return max(1, int(round(self.smoothing_s / dt)))

    def choose(self, tracks: Tracks) -> int:
        return int(np.argmax(self.scores(tracks)))


@dataclass(frozen=True)
class NearestStartTrack:
    """The person who comes nearest a start position (floor distance) within their first seconds.

    Attributes:
        start_mm: (x, y, z) mm; only the floor coordinates count.
        within_s: how long after a track appears its positions are considered.
        up_axis: index of the vertical world axis.
    """

    start_mm: tuple[float, float, float]
    within_s: float = 3.0
    up_axis: int = 2

    def distances(self, tracks: Tracks) -> np.ndarray:
        """(M,) nearest floor distance (mm) of each track to the start position."""
        _require_tracks(tracks)
        start = _floor(np.asarray(self.start_mm, float), self.up_axis)
        dist = np.linalg.norm(_floor(tracks.root_mm, self.up_axis) - start, axis=-1)  # (M, T)
        out = np.full(tracks.num_tracks, np.inf)
        for m in range(tracks.num_tracks):
            seen = np.flatnonzero(np.isfinite(dist[m]))
            early = seen[tracks.times_s[seen] - tracks.times_s[seen[0]] <= self.within_s]
            out[m] = dist[m, early].min()
        return out

    def choose(self, tracks: Tracks) -> int:
        return int(np.argmin(self.distances(tracks)))


def patient_detections(multi: MultiViewKeypoints, tracks: Tracks, track_id: int) -> MultiViewKeypoints:
    """The chosen track's 2D keypoints per camera and frame (NaN where it is not seen); detections that
    show the person mirrored (``tracks.flipped``: the detector swapped left and right) swapped back."""
    track_id = tracks.check_id(track_id)
    if tracks.camera_names != multi.camera_names:
        raise ValueError(f"tracks are for cameras {list(tracks.camera_names)}, detections for "
                         f"{list(multi.camera_names)}")
    hit = tracks.detection_track == track_id  # (C, T, P), at most one per (c, t)
    slot = np.argmax(hit, axis=-1)
    kp = np.take_along_axis(multi.keypoints, slot[:, :, None, None, None], axis=2)[:, :, 0]
    kp = np.where(hit.any(-1)[..., None, None], kp, np.nan)
    mirrored = (tracks.mirrored() & hit).any(-1)  # (C, T)
    kp = np.where(mirrored[..., None, None], kp[:, :, list(multi.skeleton.flip_permutation)], kp)
    return MultiViewKeypoints.of_one_person(kp, multi.camera_names, multi.times_s, multi.skeleton, frame_ids=multi.frame_ids,
                                            timestamps_ns=multi.timestamps_ns, provenance=multi.provenance)


def select_track_at_pixel(
    multi: MultiViewKeypoints,
    tracks: Tracks,
    *,
    camera: str,
    frame: int,
    x_px: float,
    y_px: float,
    margin_px: float = 30.0,
    confidence_threshold: float = 0.3,
) -> int:
    """The track of the person under a click on one camera's image in one frame.

    The person whose keypoint box (enlarged by ``margin_px``) contains the pixel wins; among several,
    the one with a keypoint nearest the click. ValueError naming the camera, frame and pixel if no
    tracked person is there.
    """
    if camera not in multi.camera_names:
        raise ValueError(f"camera {camera!r} is not in this trial (cameras: {list(multi.camera_names)})")
    c = multi.camera_names.index(camera)
    if not 0 <= frame < multi.shape[1]:
        raise ValueError(f"frame {frame} is outside 0..{multi.shape[1] - 1}")
    kp = multi.keypoints[c, frame]  # (P, J, 3)
    ok = multi.confident(confidence_threshold)[c, frame]
    xy = np.where(ok[..., None], kp[..., :2], np.nan)
    click = np.array([x_px, y_px], float)
    best, best_d = -1, np.inf
    for p, track in enumerate(tracks.detection_track[c, frame]):
        if track < 0 or not ok[p].any():
            continue
        lo, hi = np.nanmin(xy[p], 0) - margin_px, np.nanmax(xy[p], 0) + margin_px
        if np.all(click >= lo) and np.all(click <= hi):
            d = np.nanmin(np.linalg.norm(xy[p] - click, axis=-1))
            if d < best_d:
                best, best_d = int(track), d
    if best < 0:
        raise ValueError(f"no tracked person at pixel ({x_px:.0f}, {y_px:.0f}) of camera {camera!r} "
                         f"in frame {frame}")
    return best
