"""The health of every component, as ``/health`` and the page report it.

Components: ``database`` (a query answers), ``disk`` (free space of the data folder), ``recorder``,
``detector`` and ``workers`` (their bus liveliness tokens, since when up or down; the recorder's own
status: the trial it records, its queue; the detector's worker processes alive and its largest lag, s, a
detector without any worker process being a problem), ``cameras`` (working / seen, and which are not, judged like
the Start check). Each is ``{"ok": true | false | null, "status": words, "since": UNIX s | null}``;
``ok`` null means not attached (a catalog-only server). The overall ``status`` is ``ok`` when no
component is false, else ``degraded``.
"""

from __future__ import annotations

import shutil
import time
from pathlib import Path

from gaitcap.services import catalog as cat
from gaitcap.services.live.rig_check import RigCriteria, rig_problems
from sqlalchemy import text

MIN_FREE_BYTES = 2 * 2**30  # less free space than this on the data folder's disk is a problem


def _component(ok: bool | None, status: str, since: float | None = None, **extra) -> dict:
    return {"ok": ok, "status": status, "since": since, **extra}


def _database(catalog: cat.Catalog) -> dict:
    try:
        with catalog.reading() as s:
            s.execute(text("SELECT 1"))
        return _component(True, "ok")
    except Exception as exc:  # any failure to answer is the database's state
        first = str(getattr(exc, "orig", None) or exc).strip().splitlines()[0][:300] if str(exc).strip() else ""
        return _component(False, f"the catalog is unreachable ({type(exc).__name__}: {first}); recording goes on, "
                                 "a Stop is written once it is back")


def _disk(data_dir: Path, min_free_bytes: int) -> dict:
    folder = next((p for p in (data_dir, *data_dir.parents) if p.exists()), data_dir)  # created at first Start
    try:
        usage = shutil.disk_usage(folder)
    except OSError as exc:
        return _component(False, f"data folder {data_dir}: {exc.strerror or exc}")
    free_gb = usage.free / 2**30
    ok = usage.free >= min_free_bytes
    words = f"{free_gb:.1f} GB free" + ("" if ok else f" (below {min_free_bytes / 2**30:.1f} GB)")
    return _component(ok, words, free_gb=round(free_gb, 2))


def disk_problem(data_dir: Path, min_free_bytes: int = MIN_FREE_BYTES) -> str | None:
    """Why the data folder's disk cannot take a recording (free space below ``min_free_bytes``), or None."""
    disk = _disk(Path(data_dir), min_free_bytes)
    return None if disk["ok"] else f"data disk: {disk['status']}"


def _nodes(nodes: dict, prefix: str, what: str) -> dict:
    found = [n for name, n in nodes.items() if name == prefix or name.startswith(prefix + "-")]
    if not found:
        return _component(False, f"no {what} seen on the bus")
    up = [n for n in found if n.alive]
    if not up:
        last = max(n.since for n in found)
        return _component(False, f"down since {time.strftime('%H:%M:%S', time.localtime(last))}", last)
    return _component(True, f"{len(up)} running" if len(found) > 1 or prefix == "worker" else "running",
                      min(n.since for n in up), running=len(up))


def _recorder(nodes: dict, link) -> dict:
    comp = _nodes(nodes, "recorder", "recorder")
    if comp["ok"]:
        status = link.recorder_status()
        if status is None:
            return _component(False, "alive but not answering", comp["since"])
        words = f"recording {status['trial_id']}" if status.get("trial_id") else "ready"
        comp.update(status=words, queued=status.get("queued"))
    return comp


def _detector(nodes: dict, link) -> dict:
    """The detector nodes' liveliness, and from their coverage messages: worker processes alive of the pools'
    size and the largest lag (s); a node alive with no worker process left is a problem."""
    comp = _nodes(nodes, "detector", "detector")
    if not comp["ok"]:
        return comp
    det = link.detection()
    live = [d for d in det["nodes"].values() if not d["stale"]]
    if not live:
        return comp
    workers, pool = sum(d["workers"] for d in live), sum(d["pool"] for d in live)
    if workers == 0:
        return _component(False, f"running, but none of its {pool} detector worker processes is alive", comp["since"])
    lags = [c["lag_s"] for c in det["cameras"].values() if c.get("lag_s") is not None]
    comp.update(workers=workers, pool=pool, lag_s=max(lags) if lags else None)
    return comp


def _cameras(link) -> dict:
    cams = link.cameras()
    working = [c for c in cams if c.healthy]
    problems = rig_problems(cams, None, RigCriteria())
    bad = {c.name: c.status for c in cams if not c.healthy}
    return _component(bool(working) and not problems and not bad, f"{len(working)} of {len(cams)} working"
                      + (f"; {'; '.join(problems)}" if problems else ""), not_working=bad)


def health_report(catalog: cat.Catalog, link, data_dir: Path, *, min_free_bytes: int = MIN_FREE_BYTES) -> dict:
    """The ``/health`` body: ``status``, ``components`` and ``recorder`` (bool: a live system is attached)."""
    comps = {"database": _database(catalog), "disk": _disk(Path(data_dir), min_free_bytes)}
    if getattr(link, "connected", True):
        nodes = link.nodes()
        comps.update(recorder=_recorder(nodes, link), detector=_detector(nodes, link),
                     workers=_nodes(nodes, "worker", "worker"), cameras=_cameras(link))
    else:
        comps.update({name: _component(None, "not attached (server started without the bus)")
                      for name in ("recorder", "detector", "workers", "cameras")})
    ok = all(c["ok"] is not False for c in comps.values())
    return {"status": "ok" if ok else "degraded", "time": time.time(), "components": comps,
            "recorder": bool(getattr(link, "connected", True))}
