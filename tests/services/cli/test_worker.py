"""``gaitcap worker``'s options for fetching recordings from the rooms' recorders (``--fetch-bus``,
``--fetch-node``, ``--fetch-retry-s``) become the worker's RoomFetch."""

import json

import pytest
from gaitcap.services.bus.session import BusConfig, load_bus_config
from gaitcap.services.cli.worker import room_fetch


def test_each_rooms_bus_the_identity_and_the_retry_bound(tmp_path):
    for room in ("gait1", "gait2"):
        (tmp_path / f"bus-{room}.json").write_text(json.dumps(BusConfig.local(prefix=f"gaitcap/{room}").to_dict()))
    fetch = room_fetch([f"gait1={tmp_path / 'bus-gait1.json'}", f"gait2={tmp_path / 'bus-gait2.json'}"], "worker-gpu",
                       45.0)
    assert sorted(fetch.buses) == ["gait1", "gait2"] and fetch.buses["gait2"] == load_bus_config(tmp_path / "bus-gait2.json")
    assert (fetch.node, fetch.retry_s) == ("worker-gpu", 45.0)
    assert room_fetch([], "worker-gpu", 45.0) is None  # no room's bus: the shared store or the catalog's path
    with pytest.raises(ValueError, match="--fetch-bus: 'gait1' is not ROOM=BUSFILE"):
        room_fetch(["gait1"], "worker-gpu", 45.0)
    with pytest.raises(ValueError, match="retry_s: must be >= 0 s, got -1"):
        room_fetch([f"gait1={tmp_path / 'bus-gait1.json'}"], "worker-gpu", -1.0)


def test_the_retry_bound_defaults_to_the_fetchs_own():
    from gaitcap.services.cli import app
    from gaitcap.services.processing.room_fetch import DEFAULT_RETRY_S
    from typer.main import get_command

    options = {p.name: p for p in get_command(app).commands["worker"].params}
    assert options["fetch_retry_s"].default == DEFAULT_RETRY_S == 120.0 and "--fetch-retry-s" in options[
        "fetch_retry_s"].opts
