"""OpenSim motion (.mot) files as text: joint coordinates over time (rotations in degrees, translations in m)."""

from __future__ import annotations

import numpy as np


def to_mot(times_s: np.ndarray, coordinates: dict[str, np.ndarray], *, name: str = "ik") -> str:
    """Tab-separated .mot text (``inDegrees=yes``) of coordinates (name -> (T,)) at ``times_s`` (T,)."""
    t = np.asarray(times_s, dtype=np.float64).reshape(-1)
    cols = list(coordinates)
    wrong = [c for c in cols if np.asarray(coordinates[c]).size != t.size]
    if wrong:
        raise ValueError(f"coordinates: {', '.join(wrong)} need {t.size} values (one per time)")
    data = np.column_stack([t] + [np.asarray(coordinates[c], dtype=np.float64).reshape(-1) for c in cols])
    head = [name, "version=1", f"nRows={t.size}", f"nColumns={len(cols) + 1}", "inDegrees=yes", "endheader",
            "\t".join(["time", *cols])]
    rows = ["\t".join("NaN" if not np.isfinite(v) else f"{v:.6f}" for v in row) for row in data]
    return "\n".join(head + rows) + "\n"


def parse_mot(text: str) -> tuple[np.ndarray, dict[str, np.ndarray], bool]:
    """(times_s (T,), coordinate name -> (T,), in_degrees) of a .mot / .sto text (ValueError if malformed)."""
    lines = text.splitlines()
    try:
        end = next(i for i, line in enumerate(lines) if line.strip().lower() == "endheader")
    except StopIteration:
        raise ValueError("mot: no 'endheader' line") from None
    in_degrees = any(line.replace(" ", "").lower() == "indegrees=yes" for line in lines[:end])
    header = lines[end + 1].split("\t")
    if not header or header[0].strip() != "time":
        raise ValueError(f"mot: the first column must be 'time', got {header[:1]}")
    body = [line for line in lines[end + 2:] if line.strip()]
    data = np.array([[float(v) for v in line.split("\t")] for line in body], dtype=np.float64).reshape(
        len(body), len(header))
    return data[:, 0], {h.strip(): data[:, i] for i, h in enumerate(header) if i}, in_degrees
