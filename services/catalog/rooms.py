"""Capture rooms sharing one catalog: each room's stack (cameras, detector, recorder, API) registers under its
room name, and the catalog keeps per room its recording slot, its host and its rig state.

A room is a name of :func:`gaitcap.services.catalog.ids.validate_id`'s form, or '' (:data:`DEFAULT_ROOM`,
the one room of a single-room clinic; its slot is 1, so a catalog from before rooms reads on unchanged). A
trial records in one room and holds that room's slot while it records: one trial at a time per room,
any number of rooms at once. The rig state (what the room's API saw of its cameras) is rewritten by the
room while it runs (:func:`report_rig`); ``seen_at`` tells how fresh it is.
"""

from __future__ import annotations

import json
import time
from dataclasses import dataclass, field

from gaitcap.services.catalog.db import Catalog
from gaitcap.services.catalog.ids import validate_id
from gaitcap.services.catalog.models import Room, Trial
from sqlalchemy import func, select, update
from sqlalchemy.dialects.postgresql import insert as pg_insert
from sqlalchemy.dialects.sqlite import insert as sqlite_insert
from sqlalchemy.exc import IntegrityError
from sqlalchemy.orm import Session

DEFAULT_ROOM = ""
DEFAULT_SLOT = 1
_INSERTS = {"postgresql": pg_insert, "sqlite": sqlite_insert}  # dialect -> its INSERT ... ON CONFLICT


class RoomNotFound(KeyError):
    """No room of that name is registered."""

    def __str__(self) -> str:
        return str(self.args[0]) if self.args else "room not found"


@dataclass(frozen=True)
class RoomInfo:
    name: str
    slot: int
    host: str
    registered_at: float
    seen_at: float
    rig: dict = field(default_factory=dict)
    recording: str | None = None  # the trial recording there now


def check_room(name: str) -> str:
    """``name`` when it is '' (the default room) or a valid id; ValueError naming the field otherwise."""
    return name if name == DEFAULT_ROOM else validate_id(name, field="room")


def _info(row: Room, recording: str | None) -> RoomInfo:
    return RoomInfo(row.name, row.slot, row.host, row.registered_at, row.seen_at, json.loads(row.rig_json or "{}"),
                    recording)


def register_room(catalog: Catalog, name: str, *, host: str = "") -> RoomInfo:
    """Register room ``name`` (or update its host): it keeps its slot from an earlier registration; a new
    room gets the next free slot (the default room 1). Safe when rooms register at the same moment."""
    check_room(name)
    for _ in range(5):  # two new rooms may pick the same slot: one insert loses and tries the next
        now = time.time()
        try:
            with catalog.session() as s:
                slot = DEFAULT_SLOT if name == DEFAULT_ROOM else max(
                    DEFAULT_SLOT, s.scalar(select(func.max(Room.slot))) or DEFAULT_SLOT) + 1
                insert = _INSERTS[catalog.engine.dialect.name](Room).values(
                    name=name, slot=slot, host=host, registered_at=now, seen_at=now, rig_json="{}")
                s.execute(insert.on_conflict_do_update(index_elements=[Room.name],
                                                       set_={"host": host, "seen_at": now}))
            return get_room(catalog, name)
        except IntegrityError:
            continue
    raise RuntimeError(f"room {name!r}: could not find a free recording slot (rooms registering all at once)")


def slot_of(s: Session, name: str) -> int:
    """The recording slot of room ``name`` within a transaction (RoomNotFound when it never registered)."""
    if name == DEFAULT_ROOM:
        return DEFAULT_SLOT
    slot = s.scalar(select(Room.slot).where(Room.name == name))
    if slot is None:
        raise RoomNotFound(f"room {name!r} is not registered with this catalog (its stack registers it at start)")
    return slot


def report_rig(catalog: Catalog, name: str, rig: dict) -> None:
    """Store what room ``name`` sees of its rig now (JSON-able: cameras, their state), with the time."""
    with catalog.session() as s:
        done = s.execute(update(Room).where(Room.name == name)
                         .values(rig_json=json.dumps(rig, sort_keys=True), seen_at=time.time())).rowcount
    if done != 1:
        raise RoomNotFound(f"room {name!r} is not registered with this catalog")


def _recording(s: Session) -> dict[int, str]:
    return dict(s.execute(select(Trial.recording_slot, Trial.id).where(Trial.recording_slot.is_not(None))).all())


def get_room(catalog: Catalog, name: str) -> RoomInfo:
    with catalog.reading() as s:
        row = s.get(Room, name)
        if row is None:
            raise RoomNotFound(f"room {name!r} is not registered with this catalog")
        return _info(row, _recording(s).get(row.slot))


def list_rooms(catalog: Catalog) -> list[RoomInfo]:
    """Every registered room, by name, each with the trial recording there now."""
    with catalog.reading() as s:
        recording = _recording(s)
        return [_info(r, recording.get(r.slot)) for r in s.scalars(select(Room).order_by(Room.name))]
