"""A trial's data-quality record (table ``trial_quality``): named JSON sections, merged atomically.

Sections: ``recorder`` (the recorder's summary at Stop: frames and gaps per camera, dropped frames),
``recovery`` (a crash recovery: chunks kept, where the file was cut), ``start`` (a Start that overrode
the rig check: who, and what was wrong), ``processing`` (the worker's measures and plain-word warnings).
"""

from __future__ import annotations

import json
import time

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.models import TrialQuality
from sqlalchemy import select

SECTIONS = ("recorder", "recovery", "start", "processing")


def set_quality(catalog: Catalog, trial_id: str, section: str, value: dict) -> None:
    """Store (replace) one section of the trial's quality record (read-modify-write in one transaction)."""
    if section not in SECTIONS:
        raise ValueError(f"section: must be one of {SECTIONS}, got {section!r}")
    with catalog.session() as s:
        row = s.get(TrialQuality, trial_id)
        if row is None:
            row = TrialQuality(trial_id=trial_id, updated_at=time.time(), sections_json="{}")
            s.add(row)
        sections = json.loads(row.sections_json)
        sections[section] = value
        row.sections_json, row.updated_at = json.dumps(sections, default=float), time.time()


def get_quality(catalog: Catalog, trial_id: str) -> dict:
    """section -> value ({} when nothing was recorded)."""
    return qualities_of(catalog, [trial_id]).get(trial_id, {})


def qualities_of(catalog: Catalog, trial_ids: list[str]) -> dict[str, dict]:
    """trial id -> its quality sections (one query for many trials)."""
    with catalog.reading() as s:
        rows = s.scalars(select(TrialQuality).where(TrialQuality.trial_id.in_(trial_ids)))
        return {r.trial_id: json.loads(r.sections_json) for r in rows}


def warnings_of(sections: dict) -> list[str]:
    """The plain-word warnings of a quality record, most important first (recovery, start, processing)."""
    out: list[str] = []
    for name in ("recovery", "start", "processing", "recorder"):
        out += [w for w in (sections.get(name) or {}).get("warnings", []) if w not in out]
    return out
