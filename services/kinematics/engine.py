"""The kinematics engines' registry: ``get_engine(name)``, ``availability(name)``."""

from __future__ import annotations

from collections.abc import Callable

from gaitcap.services.kinematics.base import KinematicsEngine, KinematicsUnavailable


def _opensim() -> KinematicsEngine:
    from gaitcap.services.kinematics.opensim_engine import OpenSimEngine

    return OpenSimEngine()


ENGINES: dict[str, Callable[[], KinematicsEngine]] = {"opensim": _opensim}


def get_engine(name: str = "opensim") -> KinematicsEngine:
    """The engine, ready to run (KinematicsUnavailable saying why not; ValueError for an unknown name)."""
    if name not in ENGINES:
        raise ValueError(f"engine: must be one of {sorted(ENGINES)}, got {name!r}")
    return ENGINES[name]()


def availability(name: str = "opensim") -> tuple[bool, str]:
    """(True, "") when the engine can run, else (False, the reason)."""
    try:
        get_engine(name)
    except KinematicsUnavailable as exc:
        return False, str(exc)
    return True, ""
