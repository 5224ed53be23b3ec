"""Scoring association against ground truth (synthetic trials): identity switches and assignment errors."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class AssociationScore:
    """Association quality.

    Attributes:
        identity_switches: total over true people of the number of times the track that holds most of a
            person's detections in a frame changes from one tracked frame to the next; a person is
            tracked in a frame when at least ``min_views`` of its detections share that track (fewer
            do not make a 3D person; stray single detections count as ``wrong``).
        wrong: detections assigned to a track that is not their person's main track.
        missed: true detections left without a track.
        total: true detections (identity >= 0).
        main_track: (people,) the track holding most of each true person's detections (-1 if none).
    """

    identity_switches: int
    wrong: int
    missed: int
    total: int
    main_track: tuple[int, ...]

    @property
    def wrong_fraction(self) -> float:
        return self.wrong / max(self.total, 1)

    @property
    def missed_fraction(self) -> float:
        return self.missed / max(self.total, 1)


def score_association(detection_track: np.ndarray, identity: np.ndarray, *, min_views: int = 2) -> AssociationScore:
    """Compare assigned tracks (C, T, P) with true identities (C, T, P) (-1: empty slot / no track)."""
    if detection_track.shape != identity.shape:
        raise ValueError(f"detection_track {detection_track.shape} and identity {identity.shape} differ")
    people = int(identity.max()) + 1 if identity.size else 0
    switches, wrong, missed, main = 0, 0, 0, []
    for g in range(people):
        mine = identity == g
        tracks = np.where(mine, detection_track, -1)
        per_frame = _frame_majority(tracks.transpose(1, 0, 2).reshape(identity.shape[1], -1), min_views)
        seen = per_frame[per_frame >= 0]
        switches += int(np.count_nonzero(np.diff(seen)))
        assigned = detection_track[mine]
        ids, counts = np.unique(assigned[assigned >= 0], return_counts=True)
        best = int(ids[np.argmax(counts)]) if ids.size else -1
        main.append(best)
        missed += int(np.count_nonzero(assigned < 0))
        wrong += int(np.count_nonzero((assigned >= 0) & (assigned != best)))
    return AssociationScore(identity_switches=switches, wrong=wrong, missed=missed,
                            total=int(np.count_nonzero(identity >= 0)), main_track=tuple(main))


def _frame_majority(tracks: np.ndarray, min_count: int) -> np.ndarray:
    """(T, N) track ids (-1 none) -> (T,) the most frequent id per row (-1 when it occurs fewer than
    ``min_count`` times)."""
    t_ = tracks.shape[0]
    top = int(tracks.max()) + 1 if tracks.size else 0
    if top == 0:
        return np.full(t_, -1)
    counts = np.zeros((t_, top), int)
    rows, cols = np.nonzero(tracks >= 0)
    np.add.at(counts, (rows, tracks[rows, cols]), 1)
    return np.where(counts.max(1) >= max(min_count, 1), counts.argmax(1), -1)
