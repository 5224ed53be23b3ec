"""Camera calibrations kept in the catalog (aniposelib TOML text)."""

from __future__ import annotations

import json
import secrets
import time

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import Calibration
from sqlalchemy import select


def new_calibration_id() -> str:
    return f"C{time.strftime('%Y%m%d-%H%M%S', time.gmtime())}-{secrets.token_hex(3)}"


def add_calibration(catalog: Catalog, *, toml: str, source: str = "", report: dict | None = None,
                    cal_id: str | None = None) -> str:
    """Store a calibration; returns its id (``C<date>-<hex>``, or ``cal_id``)."""
    if not toml.strip():
        raise ValueError("toml: calibration text is empty")
    cal_id = cal_id or new_calibration_id()
    with catalog.session() as s:
        s.add(Calibration(id=cal_id, created_at=time.time(), source=source, toml=toml,
                          report_json=json.dumps(report or {}, default=float)))
    return cal_id


def latest_calibration(catalog: Catalog) -> tuple[str, str] | None:
    """(id, toml) of the newest calibration, or None."""
    with catalog.session() as s:
        row = s.scalars(select(Calibration).order_by(Calibration.created_at.desc())).first()
        return None if row is None else (row.id, row.toml)


def get_calibration(catalog: Catalog, cal_id: str) -> str:
    with catalog.session() as s:
        row = s.get(Calibration, cal_id)
        if row is None:
            raise KeyError(f"calibration {cal_id} not found")
        return row.toml
