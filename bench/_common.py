"""Helpers shared by the benchmark scripts (run as ``python bench/NAME.py``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

from gaitcap.reconstruction.jsonable import json_ready as jsonable

__all__ = ["add_trial_args", "emit", "jsonable"]


def add_trial_args(ap: argparse.ArgumentParser, *, seconds: float = 30.0, preset: str = "paper") -> None:
    """The synthetic trial's options every accuracy benchmark takes: --preset, --seconds, --cameras, --seed."""
    ap.add_argument("--preset", default=preset, choices=["clean", "paper", "hard"])
    ap.add_argument("--seconds", type=float, default=seconds)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)


def emit(result: dict, *, as_json: bool, table: Callable[[dict], object]) -> None:
    """Print one strict-JSON object (``--json``) or the readable table (``table`` prints or returns it)."""
    if as_json:
        print(json.dumps(jsonable(result)))
        return
    text = table(result)
    if text is not None:
        print(text)
