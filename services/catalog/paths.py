"""Where a deployment keeps its data by default: the one place these defaults are worked out.

``<data_dir>/catalog.sqlite`` (unless a SQLAlchemy URL is given), ``<data_dir>/trials/<trial_id>/`` for a
trial's files, ``<data_dir>/logs/`` for the stack's process logs. ``GAITCAP_DATA_DIR`` and
``GAITCAP_CATALOG`` override them in every command and in the API's settings.
"""

from __future__ import annotations

from pathlib import Path

DEFAULT_DATA_DIR = Path("runs/clinic")
"""The data folder of ``gaitcap serve``, ``worker``, the nodes and the research commands."""
DEMO_DATA_DIR = Path("runs/demo")
"""The data folder of ``gaitcap demo``."""
CATALOG_FILE = "catalog.sqlite"


def catalog_url(data_dir: str | Path, catalog: str | None = None) -> str:
    """The catalog to open: ``catalog`` (a SQLite path or SQLAlchemy URL) if given, else
    ``<data_dir>/catalog.sqlite``."""
    return catalog or str(Path(data_dir) / CATALOG_FILE)
