"""Reconstruction methods named on the command line or in a sweep grid, as typed configs with a stable
identity.

A :class:`MethodSpec` is a method name from :data:`gaitcap.reconstruction.methods.METHODS` (``dlt``, ``robust``,
``explicit``, ``implicit``), an optional preset (a constructor of the config class, e.g. ``paper``) and
parameter overrides. Overrides are dotted paths into the frozen config (``fit.solver.iterations=30``,
``robust.gamma=0.3``) or one of the short :data:`ALIASES` (``gamma``, ``sigma_mm``, ``huber_cut_px``,
``use_confidence``, ``iterations``). Text form (CLI)::

    robust                         implicit:gamma=0.3,huber_cut_px=10
    robust:sigma_mm=100            explicit@paper:fit.solver.steps=2000

The identity of a result is ``(trial, method, params_key)``: ``params_key`` hashes the FULL resolved
config (every field, nested, with the class of each part; :mod:`gaitcap.services.catalog.method_keys`, which
keys the clinic's stages too), so two spellings of the same config share results, and a changed default
gives a new key instead of a stale result.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

from gaitcap.reconstruction.methods import METHODS
from gaitcap.services.catalog.method_keys import canonical, params_key

__all__ = ["ALIASES", "MethodSpec", "canonical", "parse_method"]

#: short names -> dotted paths tried in order (the first that exists in the config is used).
ALIASES: dict[str, tuple[str, ...]] = {
    "gamma": ("gamma", "robust.gamma"),
    "sigma_mm": ("sigma_mm", "robust.sigma_mm"),
    "huber_cut_px": ("fit.loss.cut_px",),
    "huber_delta_px": ("fit.loss.huber_delta_px",),
    "smooth_weight": ("fit.loss.smooth_weight",),
    "skeleton_weight": ("fit.loss.skeleton_weight",),
    "iterations": ("fit.solver.iterations",),
    "steps": ("fit.solver.steps",),
    "max_freq_hz": ("fit.model.max_freq_hz",),
}
NONE_WORDS = ("none", "null", "off")


@dataclass(frozen=True)
class MethodSpec:
    """One method variant: ``method`` (METHODS name), ``preset`` (class constructor name or ""),
    ``params`` (override path -> value, JSON-ready), ``label`` (table row name; default from the rest)."""

    method: str
    params: dict[str, Any] = field(default_factory=dict)
    preset: str = ""
    label: str = ""

    def __post_init__(self) -> None:
        if self.method not in METHODS:
            raise ValueError(f"method: unknown method {self.method!r}; known: {', '.join(sorted(METHODS))}")
        if self.preset and not callable(getattr(METHODS[self.method], self.preset, None)):
            raise ValueError(f"method {self.method}: unknown preset {self.preset!r}")
        object.__setattr__(self, "params", dict(sorted(self.params.items())))
        self.config()  # fails early, naming the bad parameter

    def config(self):
        """The typed method config (a frozen dataclass of :mod:`gaitcap.reconstruction.methods`)."""
        cls = METHODS[self.method]
        cfg = getattr(cls, self.preset)() if self.preset else cls()
        for name, value in self.params.items():
            cfg = _set_path(cfg, _resolve(cfg, name, self.method), value, name)
        return cfg

    @property
    def key(self) -> str:
        """Stable hash (16 hex) of the full resolved config (:func:`~gaitcap.services.catalog.method_keys.params_key`,
        the key the clinic's stages are stored under too)."""
        return params_key(self.config())

    @property
    def name(self) -> str:
        """Row name: the label, else e.g. ``implicit gamma=0.3 huber_cut_px=10``."""
        if self.label:
            return self.label
        head = self.method + (f"@{self.preset}" if self.preset else "")
        return " ".join([head, *(f"{k}={_fmt(v)}" for k, v in self.params.items())])

    def to_dict(self) -> dict[str, Any]:
        return {"method": self.method, "preset": self.preset, "params": dict(self.params), "label": self.label}


def parse_method(text: str) -> MethodSpec:
    """``name[@preset][:key=value,key=value]`` -> MethodSpec (values: numbers, true/false, none)."""
    head, _, rest = text.strip().partition(":")
    name, _, preset = head.partition("@")
    params = {}
    for item in filter(None, (p.strip() for p in rest.split(","))):
        key, sep, value = item.partition("=")
        if not sep or not key.strip():
            raise ValueError(f"method {text!r}: parameter {item!r} is not key=value")
        params[key.strip()] = _parse_value(value.strip())
    return MethodSpec(name.strip(), params, preset.strip())


def _parse_value(text: str) -> Any:
    low = text.lower()
    if low in NONE_WORDS:
        return None
    if low in ("true", "false"):
        return low == "true"
    for kind in (int, float):
        try:
            return kind(text)
        except ValueError:
            pass
    return text


def _fmt(value: Any) -> str:
    return "none" if value is None else str(value).lower() if isinstance(value, bool) else str(value)


def _has_path(cfg, path: str) -> bool:
    for part in path.split("."):
        if not dataclasses.is_dataclass(cfg) or part not in {f.name for f in dataclasses.fields(cfg)}:
            return False
        cfg = getattr(cfg, part)
    return True


def _resolve(cfg, name: str, method: str) -> str:
    for path in (name, *ALIASES.get(name, ())):
        if _has_path(cfg, path):
            return path
    raise ValueError(f"method {method}: unknown parameter {name!r} (not a field of {type(cfg).__name__}"
                     f"{'' if name not in ALIASES else ' nor of ' + ', '.join(ALIASES[name])})")


def _coerce(old: Any, value: Any, name: str) -> Any:
    """``value`` converted to the type of the field's current value (bool, int, float, None allowed)."""
    if value is None or old is None:
        return value
    if isinstance(old, bool):
        if not isinstance(value, bool):
            raise ValueError(f"parameter {name}: expected true/false, got {value!r}")
        return value
    if isinstance(old, int | float):
        if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
            raise ValueError(f"parameter {name}: expected a finite number, got {value!r}")
        if isinstance(old, int) and float(value) != int(value):
            raise ValueError(f"parameter {name}: expected an integer, got {value!r}")
        return type(old)(value)
    raise ValueError(f"parameter {name}: {type(old).__name__} fields cannot be set from text")


def _set_path(cfg, path: str, value: Any, name: str):
    head, _, rest = path.partition(".")
    old = getattr(cfg, head)
    new = _set_path(old, rest, value, name) if rest else _coerce(old, value, name)
    try:
        return dataclasses.replace(cfg, **{head: new})
    except (TypeError, ValueError) as exc:
        raise ValueError(f"parameter {name}: {exc}") from None
