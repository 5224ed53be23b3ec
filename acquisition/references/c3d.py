"""A C3D reference (marker system) read with ezc3d: markers, the EVENT group, model outputs (angles).

C3D event times are absolute (the capture's clock): the file's first frame is at
``(TRIAL:ACTUAL_START_FIELD - 1) / rate`` s (without that parameter, the header's first frame, which
ezc3d counts from 0); the reference clock starts at that frame. EVENT:TIMES holds (minutes, seconds)
pairs. Contexts ``Left``/``Right``, labels ``Foot Strike`` / ``Foot Off`` (Vicon's names).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from gaitcap.reconstruction.validation.reference import Reference, map_angles, map_markers

_KINDS = {"foot strike": "heel_strike", "foot off": "toe_off"}
_SIDES = {"left": "left", "right": "right"}
_UNITS = {"mm": 1.0, "m": 1000.0, "cm": 10.0}


def _value(params, group: str, name: str, default=None):
    try:
        return params[group][name]["value"]
    except KeyError:
        return default


def _labels(params) -> list[str]:
    labels = list(_value(params, "POINT", "LABELS", []))
    k = 2
    while _value(params, "POINT", f"LABELS{k}") is not None:  # files with more than 255 points
        labels += list(_value(params, "POINT", f"LABELS{k}"))
        k += 1
    return [str(x).strip() for x in labels]


def c3d_events(params, start_s: float, source: str) -> tuple[dict, dict] | tuple[None, None]:
    """(heel strikes, toe offs): side -> (K,) sorted times (s) on the file's clock (EVENT group's times
    less ``start_s``, the trial's start), from a C3D's parameters; (None, None) without an EVENT group."""
    contexts = [str(x).strip().lower() for x in _value(params, "EVENT", "CONTEXTS", [])]
    labels = [str(x).strip().lower() for x in _value(params, "EVENT", "LABELS", [])]
    if not contexts:
        return None, None
    times = np.asarray(_value(params, "EVENT", "TIMES", []), dtype=np.float64)
    times = times.reshape(2, -1) if times.ndim == 2 else times.reshape(-1, 2).T  # rows: minutes, seconds
    if times.shape[1] != len(contexts) or len(labels) != len(contexts):
        raise ValueError(f"{source}: EVENT group has {len(contexts)} contexts, {len(labels)} labels and "
                         f"{times.shape[1]} times")
    out = {kind: {s: [] for s in _SIDES.values()} for kind in _KINDS.values()}
    for ctx, label, t in zip(contexts, labels, 60.0 * times[0] + times[1], strict=True):
        kind, side = _KINDS.get(label), _SIDES.get(ctx)
        if kind and side:
            out[kind][side].append(float(t) - start_s)
    hs = {s: np.sort(np.array(v)) for s, v in out["heel_strike"].items()}
    to = {s: np.sort(np.array(v)) for s, v in out["toe_off"].items()}
    return hs, to


@dataclass(frozen=True, eq=False)
class C3DPoints:
    """A C3D file's points as read once for every user (the validation's reference, the simulator's real
    walks): ``rate_hz``; ``start_s`` the trial's start on the capture clock (``(first frame - 1) / rate``);
    ``labels``; ``outputs`` the labels that are model outputs (angles, forces, ...: not positions);
    ``unit_mm`` millimetres per point unit; ``params`` ezc3d's parameter tree. Samples with a negative
    residual or all zero (Vicon's gap) are NaN."""

    source: str
    rate_hz: float
    start_s: float
    labels: tuple[str, ...]
    outputs: frozenset[str]
    unit_mm: float
    params: dict
    data: np.ndarray  # (3, N, T) in the file's unit, gaps NaN

    @property
    def times_s(self) -> np.ndarray:
        """(T,) s from the file's first frame."""
        return np.arange(self.data.shape[2]) / self.rate_hz

    def raw(self, label: str) -> np.ndarray:
        """(T, 3) of ``label`` as stored (degrees for an angle); KeyError naming a missing label. A lab's
        ``V``-suffixed copy of a model output is taken where the plain label is absent."""
        for name in (label, f"{label}V"):
            if name in self.labels:
                return self.data[:, self.labels.index(name), :].T.copy()
        raise KeyError(f"C3D: no point {label!r}")

    def marker_mm(self, label: str) -> np.ndarray:
        """(T, 3) mm of marker ``label`` (KeyError when absent)."""
        return self.raw(label) * self.unit_mm


def open_c3d(path: Path) -> C3DPoints:
    """Read a C3D's points (ValueError naming the file: unreadable, no POINT:RATE)."""
    try:
        import ezc3d
    except ImportError as exc:
        raise RuntimeError(f"reading C3D needs the 'ezc3d' package ({exc})") from None
    source = str(path)
    try:
        c = ezc3d.c3d(source, extract_forceplat_data=False)
    except (RuntimeError, ValueError) as exc:
        raise ValueError(f"{source}: not a readable C3D file ({exc})") from None
    params = c["parameters"]
    rate = float(np.ravel(_value(params, "POINT", "RATE", [0.0]))[0])
    if rate <= 0:
        raise ValueError(f"{source}: POINT:RATE is missing")
    data = np.asarray(c["data"]["points"], dtype=np.float64)[:3].copy()  # (3, N, T)
    residuals = np.asarray(c["data"].get("meta_points", {}).get("residuals", []), dtype=np.float64)
    gap = (data == 0).all(axis=0)  # (N, T)
    if residuals.shape[1:] == gap.shape:  # a file written without residuals has none
        gap |= residuals[0] < 0
    data[:, gap] = np.nan
    labels = tuple(_labels(params)[: data.shape[1]])
    first = _value(params, "TRIAL", "ACTUAL_START_FIELD")
    first_frame = int(np.ravel(first)[0]) if first is not None else int(c["header"]["points"]["first_frame"]) + 1
    outputs = frozenset(str(x).strip() for k in ("ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS")
                        for x in (_value(params, "POINT", k, []) or []))
    units = np.ravel(_value(params, "POINT", "UNITS", ["mm"]))  # an empty UNITS means mm too
    unit = str(units[0]).strip().lower() if len(units) else "mm"
    return C3DPoints(source, rate, (first_frame - 1) / rate, labels, outputs, _UNITS.get(unit, 1.0), params, data)


def read_c3d(path: Path) -> Reference:
    """The reference in a C3D file (ValueError naming the file: unreadable, no markers to compare)."""
    c = open_c3d(path)
    source = c.source
    markers, angles = {}, {}
    for label in c.labels:
        if label in c.outputs:
            angles[label] = c.raw(label)
        else:
            markers[label] = c.marker_mm(label)
    joints, used = map_markers(markers)
    if not joints:
        raise ValueError(f"{source}: no heel, ankle, knee, hip or toe markers (Plug-in-Gait labels such as "
                         f"LHEE, LANK) to compare with")
    hs, to = c3d_events(c.params, c.start_s, source)
    lacks = []
    if hs is None or not any(len(v) for v in hs.values()):
        lacks.append("gait events (no Foot Strike in the EVENT group)")
        hs, to = None, None
    angle_curves = map_angles(angles)
    if not angle_curves:
        lacks.append("joint angles (no model outputs such as LKneeAngles)")
    return Reference(source, "C3D", c.times_s, joints, used, hs, to, angle_curves, None, tuple(lacks))
