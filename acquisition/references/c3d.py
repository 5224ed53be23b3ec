"""A C3D reference (marker system) read with ezc3d: markers, the EVENT group, model outputs (angles).

C3D event times are absolute (the capture's clock): the file's first frame is at
``(TRIAL:ACTUAL_START_FIELD - 1) / rate`` s (without that parameter, the header's first frame, which
ezc3d counts from 0); the reference clock starts at that frame. EVENT:TIMES holds (minutes, seconds)
pairs. Contexts ``Left``/``Right``, labels ``Foot Strike`` / ``Foot Off`` (Vicon's names).
"""

from __future__ import annotations

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


def read_c3d(path: Path) -> Reference:
    """The reference in a C3D file (ValueError naming the file: unreadable, no markers to compare)."""
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
    data = np.asarray(c["data"]["points"], dtype=np.float64)[:3]  # (3, N, T)
    labels = _labels(params)[: data.shape[1]]
    first = _value(params, "TRIAL", "ACTUAL_START_FIELD")
    first_frame = int(np.ravel(first)[0]) if first is not None else int(c["header"]["points"]["first_frame"]) + 1
    start_s = (first_frame - 1) / rate
    times = np.arange(data.shape[2]) / rate
    outputs = {str(x).strip() for k in ("ANGLES", "FORCES", "MOMENTS", "POWERS", "SCALARS", "REACTIONS")
               for x in (_value(params, "POINT", k, []) or [])}
    unit = str(np.ravel(_value(params, "POINT", "UNITS", ["mm"]))[0]).strip().lower()
    scale = _UNITS.get(unit, 1.0)
    markers, angles = {}, {}
    for k, label in enumerate(labels):
        p = data[:, k, :].T.copy()
        p[(p == 0).all(axis=1)] = np.nan  # an all-zero sample is Vicon's gap
        if label in outputs:
            angles[label] = p
        else:
            markers[label] = p * scale
    joints, used = map_markers(markers)
    if not joints:
        raise ValueError(f"{source}: no heel, ankle, knee, hip or toe markers (Plug-in-Gait labels such as "
                         f"LHEE, LANK) to compare with")
    hs, to = c3d_events(params, start_s, source)
    lacks = []
    if hs is None or not any(len(v) for v in hs.values()):
        lacks.append("gait events (no Foot Strike in the EVENT group)")
        hs, to = None, None
    angle_curves = map_angles(angles)
    if not angle_curves:
        lacks.append("joint angles (no model outputs such as LKneeAngles)")
    return Reference(source, "C3D", times, joints, used, hs, to, angle_curves, None, tuple(lacks))
