"""The parameters key of a stored result: which method config computed it, as a short stable hash.

Every result in the catalog that a method config computed is keyed by (trial, method, params_key): the
clinic's stages (:mod:`gaitcap.services.catalog.results`) and research reprocessing
(:mod:`gaitcap.services.catalog.method_results`) compute the key here, one way, so the same config on the
same trial finds the same key whoever computed it.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
from typing import Any


def canonical(obj: Any) -> Any:
    """A JSON-ready description of a config: dataclasses as {"type": class, fields...}, recursively."""
    if dataclasses.is_dataclass(obj) and not isinstance(obj, type):
        return {"type": type(obj).__name__, **{f.name: canonical(getattr(obj, f.name))
                                               for f in dataclasses.fields(obj)}}
    if isinstance(obj, list | tuple):
        return [canonical(v) for v in obj]
    if isinstance(obj, dict):
        return {str(k): canonical(v) for k, v in obj.items()}
    if isinstance(obj, float) and not math.isfinite(obj):
        return str(obj)
    if obj is None or isinstance(obj, bool | int | float | str):
        return obj
    return repr(obj)


def params_key(config: Any, *, inputs: dict[str, str] | None = None) -> str:
    """Stable hash (16 hex) of a method's FULL resolved config (:func:`canonical`), so two spellings of one
    config share the key and a changed default gives a new one. ``inputs``: what the result was computed
    from besides the trial's recorded keypoints and calibration (e.g. ``{"calibration": <version id>}``),
    folded in so that such a result never shares the key of one computed from the recording alone."""
    described = canonical(config) if not inputs else {"config": canonical(config), "inputs": dict(sorted(inputs.items()))}
    text = json.dumps(described, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]
