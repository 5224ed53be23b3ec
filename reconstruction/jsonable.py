"""The one JSON-ready converter: NumPy values, tuples and non-finite floats made strict-JSON safe.

Results carry NaN where something could not be measured (a camera without views, a step without a
contralateral heel); strict JSON has no NaN, so they become ``null`` everywhere a result is written or
served.
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any


def finite_or_none(value: Any) -> float | None:
    """``float(value)`` if it is a finite number, else None (None, NaN, inf, or not a number)."""
    try:
        number = float(value)
    except (TypeError, ValueError):
        return None
    return number if math.isfinite(number) else None


def json_ready(value: Any) -> Any:
    """A copy of ``value`` with dataclasses and dicts as dicts (keys as str), tuples and arrays as lists,
    NumPy scalars as Python numbers and NaN/inf as None; booleans, ints, strings and None pass through."""
    if dataclasses.is_dataclass(value) and not isinstance(value, type):
        return {f.name: json_ready(getattr(value, f.name)) for f in dataclasses.fields(value)}
    if isinstance(value, dict):
        return {str(k): json_ready(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [json_ready(v) for v in value]
    if hasattr(value, "tolist"):  # NumPy arrays and scalars, JAX arrays
        return json_ready(value.tolist())
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    return value
