"""Helpers shared by the benchmark scripts (run as ``python bench/NAME.py``)."""

from __future__ import annotations

import argparse
import json
from collections.abc import Callable

from gaitcap.reconstruction.jsonable import json_ready as jsonable

__all__ = ["add_foot_arg", "add_trial_args", "emit", "implicit_method", "jsonable"]


def add_trial_args(ap: argparse.ArgumentParser, *, seconds: float = 30.0, preset: str = "paper") -> None:
    """The synthetic trial's options every accuracy benchmark takes: --preset, --seconds, --cameras, --seed."""
    ap.add_argument("--preset", default=preset, choices=["clean", "paper", "hard"])
    ap.add_argument("--seconds", type=float, default=seconds)
    ap.add_argument("--cameras", type=int, default=10)
    ap.add_argument("--seed", type=int, default=0)


def add_foot_arg(ap: argparse.ArgumentParser, *, knees: bool = False) -> None:
    """--foot-hz (and with ``knees`` --knee-hz): the implicit fit's fast grid (by default the knees at 12 Hz)
    with the feet (ankles, heels, toes) on it too at that band limit, or the knees' grid at that band limit
    (``--knee-hz 8``: the body's band, as before the knees had a grid of their own)."""
    grid = ap.add_mutually_exclusive_group()
    grid.add_argument("--foot-hz", type=float, default=None,
                      help="the implicit fit's feet (with the knees) on their own knot grid at this band limit (Hz)")
    if knees:
        grid.add_argument("--knee-hz", type=float, default=None,
                          help="the implicit fit's knees' own knot grid at this band limit (Hz; default 12)")


def implicit_method(foot_hz: float | None = None, *, knee_hz: float | None = None):
    """The default implicit fit; with ``foot_hz`` the feet on its B-spline model's fast grid with the knees at
    that band limit, with ``knee_hz`` the knees' grid at that band limit (``fast_max_freq_hz``, ``fast_joints``)."""
    import dataclasses

    from gaitcap.reconstruction.fits.bspline import FOOT_JOINTS, KNEE_JOINTS
    from gaitcap.reconstruction.methods import Implicit

    method = Implicit()
    if foot_hz is None and knee_hz is None:
        return method
    hz, joints = (foot_hz, KNEE_JOINTS + FOOT_JOINTS) if foot_hz is not None else (knee_hz, KNEE_JOINTS)
    model = dataclasses.replace(method.fit.model, fast_max_freq_hz=hz, fast_joints=joints)
    return dataclasses.replace(method, fit=dataclasses.replace(method.fit, model=model))


def emit(result: dict, *, as_json: bool, table: Callable[[dict], object]) -> None:
    """Print one strict-JSON object (``--json``) or the readable table (``table`` prints or returns it)."""
    if as_json:
        print(json.dumps(jsonable(result)))
        return
    text = table(result)
    if text is not None:
        print(text)
