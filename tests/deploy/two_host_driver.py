"""Runs on a room's PROCESSING host in the two-room test (inside its network namespace): records one trial
through the room's recorder node as the clinic service does, against the central catalog, then stops it as
the API's Stop does (:mod:`gaitcap.api.routes_trials`): ``recording -> stopping``, the recorder stopped, its
summary and checksum written, processing queued; when the catalog is unreachable at Stop, the recorder is
stopped all the same and the catalog writes wait in :class:`~gaitcap.services.live.pending_stops.PendingStops`.

Protocol on stdin/stdout (one JSON object per line): prints {"event": "recording", "trial_id"} once the
recorder has started; waits for a line "stop" on stdin; stops the recording and prints {"event": "stopped",
"pending"} (pending: the catalog was unreachable); once the catalog writes are done prints {"event": "queued",
"summary"}.

    python two_host_driver.py BUS_FILE DATA_DIR SIM_JSON [CATALOG_URL ROOM]

Without CATALOG_URL and ROOM (the one-room GigE Vision trial test): DATA_DIR's own SQLite catalog and the
default room; SIM_JSON's ``fps`` defaults to 30.
"""

import json
import sys
import time
from pathlib import Path


def _wait_for_nodes(session, bus, needed: set[str]) -> None:
    from gaitcap.services.bus.session import alive_nodes

    deadline = time.monotonic() + 120
    while not needed <= alive_nodes(session, bus):
        if time.monotonic() > deadline:
            raise SystemExit(f"nodes not seen on the bus: {sorted(needed - alive_nodes(session, bus))}")
        time.sleep(0.2)


def _stop(db, recorder, trial_id: str) -> tuple[dict, bool]:
    """The API's Stop: (the recorder's summary, whether the catalog writes wait for the catalog)."""
    from gaitcap.services import catalog as cat
    from gaitcap.services.live.pending_stops import PendingStop, PendingStops, finish_stop
    from sqlalchemy.exc import OperationalError

    try:
        trial = cat.set_state(db, trial_id, "stopping", expect="recording", stage="saving the recording")
    except OperationalError:  # the catalog is unreachable: stop the recorder, the writes wait
        summary = recorder.stop(trial_id).summary
        print(json.dumps({"event": "stopped", "pending": True}), flush=True)
        pending = PendingStops(db, period_s=0.5).start()
        pending.add(PendingStop(trial_id=trial_id, summary=summary, actor="driver", stopped_at=time.time()))
        deadline = time.monotonic() + 120
        while pending.ids() and time.monotonic() < deadline:
            time.sleep(0.1)
        pending.close()
        return summary, True
    summary = recorder.stop(trial_id).summary
    print(json.dumps({"event": "stopped", "pending": False}), flush=True)
    finish_stop(db, trial, summary, stopped_at=time.time())
    return summary, False


def main() -> None:
    bus_file, data_dir, sim = Path(sys.argv[1]), Path(sys.argv[2]), json.loads(sys.argv[3])
    catalog_url, room = (sys.argv[4], sys.argv[5]) if len(sys.argv) > 5 else (str(data_dir / "catalog.sqlite"), "")
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text
    from gaitcap.services import catalog as cat
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import load_bus_config, open_session
    from gaitcap.services.catalog import rooms
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.simulator import make_trial

    bus = load_bus_config(bus_file)
    rig = make_trial(sim["preset"], seconds=sim["seconds"], cameras=sim["cameras"], seed=sim["seed"], fps=sim.get("fps", 30.0)).rig
    session = open_session(bus, None)
    _wait_for_nodes(session, bus, {"recorder", "detector", "worker"})
    db = cat.open_catalog(catalog_url)
    if room:
        rooms.register_room(db, room, host=f"{room}-host")
    trial = cat.start_trial(db, subject_id="P-netns", session="s1", room=room,
                            recording_path_for=lambda tid: trial_files(data_dir, tid).recording)
    Path(trial.recording_path).parent.mkdir(parents=True, exist_ok=True)
    recorder = RecorderClient(session, bus.keys, timeout_s=20)
    recorder.start(trial_id=trial.id, path=trial.recording_path, metadata={"trial_id": trial.id},
                   calibration_toml=rig_to_toml_text(rig), cameras=list(rig.names))
    last = [time.monotonic()]
    sub = session.declare_subscriber(bus.keys.keypoints(), lambda _s: last.__setitem__(0, time.monotonic()))
    print(json.dumps({"event": "recording", "trial_id": trial.id}), flush=True)
    if sys.stdin.readline().strip() != "stop":
        raise SystemExit("expected 'stop' on stdin")
    deadline = time.monotonic() + 30
    while time.monotonic() - last[0] < 1.5 and time.monotonic() < deadline:  # the detector's last keypoints
        time.sleep(0.1)
    while recorder.status().queued and time.monotonic() < deadline:
        time.sleep(0.1)
    sub.undeclare()
    summary, _pending = _stop(db, recorder, trial.id)
    print(json.dumps({"event": "queued", "trial_id": trial.id, "summary": summary}), flush=True)
    session.close()


if __name__ == "__main__":
    main()
