"""Board coverage while a board recording runs: per camera, which cells of its image have had board
views, and per pair of cameras, in how many moments both saw the board; with advice in words on where
to move the board before Stop.

A camera's image is cut into ``grid`` x ``grid`` cells (rows top to bottom, columns left to right); a
board view counts once in every cell holding at least one of its corners. Views of several cameras
belong to one moment when their camera timestamps lie within ``together_ns`` of the moment's first
view (sorted by time); a camera counts once per moment. A pair of cameras shares a view in every moment
that holds both. Regions are named on a 3 x 3 reading of the image (upper left ... lower right); a
region is named as empty only when every cell of it is.

Pure: sightings in, counts and words out (the live system's board views feed it,
``gaitcap.services.live.board_coverage``).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from itertools import combinations

import numpy as np
from scipy.sparse import csr_matrix
from scipy.sparse.csgraph import connected_components

GRID = 4
MAX_PAIR_LINES = 6  # more camera pairs without a shared view are summed up in one line
_ROW_WORDS = ("upper", "", "lower")
_COL_WORDS = ("left", "", "right")
_EDGE_WORDS = {(0, 1): "top", (1, 0): "left", (1, 1): "centre", (1, 2): "right", (2, 1): "bottom"}


@dataclass(frozen=True)
class BoardSighting:
    """One camera's view of the board in one frame.

    Attributes:
        camera: camera name.
        time_ns: the frame's camera timestamp, ns.
        cells: grid cells (row-major index ``row * grid + col``) holding at least one of its corners.
    """

    camera: str
    time_ns: int
    cells: tuple[int, ...]


def board_cells(corners_px: np.ndarray, *, width_px: int, height_px: int, grid: int = GRID) -> tuple[int, ...]:
    """The cells (sorted row-major indices) of a ``grid`` x ``grid`` cutting of a ``width_px`` x
    ``height_px`` image that hold at least one of ``corners_px`` ((N, 2) px, pixel centres at integers;
    NaN rows, corners not found, are ignored; corners outside the image count in the nearest cell)."""
    if width_px < 1 or height_px < 1 or grid < 1:
        raise ValueError(f"board_cells: image {width_px} x {height_px} px and grid {grid} must be positive")
    pts = np.asarray(corners_px, dtype=np.float64).reshape(-1, 2)
    pts = pts[np.isfinite(pts).all(axis=1)]
    col = np.clip(np.floor((pts[:, 0] + 0.5) * grid / width_px), 0, grid - 1).astype(int)
    row = np.clip(np.floor((pts[:, 1] + 0.5) * grid / height_px), 0, grid - 1).astype(int)
    return tuple(sorted({int(i) for i in row * grid + col}))


def region_of(row: int, col: int, grid: int) -> str:
    """The 3 x 3 region word of cell (``row``, ``col``) of a ``grid`` x ``grid`` cutting ("upper left",
    "top", ..., "centre", ..., "lower right"), by the cell's centre."""
    r, c = (min(2, int((i + 0.5) * 3 / grid)) for i in (row, col))
    return _EDGE_WORDS.get((r, c)) or f"{_ROW_WORDS[r]} {_COL_WORDS[c]}"


@dataclass(frozen=True)
class CameraCoverage:
    """One camera's board views: ``views`` in all; ``cells`` (grid, grid) views with a corner in each cell."""

    name: str
    views: int
    cells: tuple[tuple[int, ...], ...]

    @property
    def grid(self) -> int:
        return len(self.cells)

    def empty_cells(self) -> list[tuple[int, int]]:
        return [(r, c) for r, row in enumerate(self.cells) for c, n in enumerate(row) if n == 0]

    def empty_regions(self) -> list[str]:
        """The 3 x 3 regions (in reading order) none of whose cells has had a view."""
        regions: dict[str, bool] = {}
        for r, row in enumerate(self.cells):
            for c, n in enumerate(row):
                word = region_of(r, c, self.grid)
                regions[word] = regions.get(word, True) and n == 0
        return [word for word, empty in regions.items() if empty]


@dataclass(frozen=True)
class BoardCoverage:
    """Every camera's coverage and the moments each pair of cameras saw the board together.

    Attributes:
        grid: cells per image side.
        cameras: per camera (in the order asked for).
        pairs: ((camera a, camera b), moments both saw the board) for every pair, a before b as in ``cameras``.
        moments: moments with at least one view.
    """

    grid: int
    cameras: tuple[CameraCoverage, ...]
    pairs: tuple[tuple[tuple[str, str], int], ...]
    moments: int

    def groups(self) -> list[list[str]]:
        """The cameras with views, split where no pair of cameras joins two groups by a shared view
        (one group: every camera with views is linked to the others through shared views)."""
        seen = [c.name for c in self.cameras if c.views]
        index = {n: i for i, n in enumerate(seen)}
        edges = [(index[a], index[b]) for (a, b), n in self.pairs if n and a in index and b in index]
        if not seen:
            return []
        rows, cols = zip(*edges, strict=True) if edges else ((), ())
        graph = csr_matrix((np.ones(len(edges)), (rows, cols)), shape=(len(seen), len(seen)))
        _, labels = connected_components(graph, directed=False)
        out: dict[int, list[str]] = {}
        for name, label in zip(seen, labels, strict=True):
            out.setdefault(int(label), []).append(name)
        return list(out.values())

    def advice(self) -> tuple[str, ...]:
        """Where to move the board, in words: cameras without a view, regions without a view, cameras
        not linked to the others through shared views, and camera pairs that share none."""
        lines = []
        for cam in self.cameras:
            if not cam.views:
                lines.append(f"{cam.name}: no board view yet: show it the board")
                continue
            regions, cells = cam.empty_regions(), cam.empty_cells()
            if regions:
                lines.append(f"{cam.name}: no views in the {', '.join(regions)}")
            elif cells:
                lines.append(f"{cam.name}: {len(cells)} of {self.grid * self.grid} image cells without a view")
        groups = self.groups()
        if len(groups) > 1:
            words = "; ".join(", ".join(g) for g in groups)
            lines.append(f"no shared view links these groups of cameras: {words}: hold the board where cameras "
                         "of two groups both see it")
        unshared = [pair for pair, n in self.pairs if n == 0]
        if len(unshared) <= MAX_PAIR_LINES:
            lines += [f"{a}-{b} share no view: hold the board where both see it" for a, b in unshared]
        else:
            lines.append(f"{len(unshared)} of {len(self.pairs)} camera pairs share no view (see the pair table)")
        return tuple(lines)

    def to_dict(self) -> dict:
        """JSON-ready: grid, moments, cameras [{name, views, cells}], pairs [{cameras, together}], advice."""
        return {"grid": self.grid, "moments": self.moments,
                "cameras": [{"name": c.name, "views": c.views, "cells": [list(r) for r in c.cells]}
                            for c in self.cameras],
                "pairs": [{"cameras": list(p), "together": n} for p, n in self.pairs],
                "advice": list(self.advice())}


def moments_of(sightings: Iterable[BoardSighting], together_ns: int) -> list[set[str]]:
    """The cameras of each moment (views sorted by time; a view within ``together_ns`` of its moment's
    first view joins it, else it starts the next moment)."""
    out: list[set[str]] = []
    start = None
    for s in sorted(sightings, key=lambda s: (s.time_ns, s.camera)):
        if start is None or s.time_ns - start > together_ns:
            start = s.time_ns
            out.append(set())
        out[-1].add(s.camera)
    return out


def board_coverage(sightings: Sequence[BoardSighting], *, cameras: Sequence[str], grid: int = GRID,
                   together_ns: int) -> BoardCoverage:
    """The coverage of ``cameras`` (sightings of other cameras are left out) on a ``grid`` x ``grid``
    cutting; views within ``together_ns`` (ns) of a moment's first view are one moment."""
    if together_ns < 0:
        raise ValueError(f"board_coverage: together_ns must be >= 0, got {together_ns}")
    names = list(dict.fromkeys(cameras))
    counts = {n: np.zeros(grid * grid, dtype=int) for n in names}
    views = dict.fromkeys(names, 0)
    kept = [s for s in sightings if s.camera in counts]
    for s in kept:
        bad = [i for i in s.cells if not 0 <= i < grid * grid]
        if bad:
            raise ValueError(f"board_coverage: camera {s.camera}: cells {bad} outside a {grid} x {grid} grid")
        views[s.camera] += 1
        counts[s.camera][list(set(s.cells))] += 1
    moments = moments_of(kept, together_ns)
    pairs = tuple(((a, b), sum(1 for m in moments if a in m and b in m)) for a, b in combinations(names, 2))
    cams = tuple(CameraCoverage(n, views[n], tuple(tuple(int(x) for x in r) for r in counts[n].reshape(grid, grid)))
                 for n in names)
    return BoardCoverage(grid, cams, pairs, len(moments))
