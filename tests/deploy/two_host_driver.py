"""Runs on the PROCESSING host of the two-host test (inside its network namespace): records one trial
through the recorder node as the clinic service would, then queues it for the worker.

Protocol on stdin/stdout (one JSON object per line): prints {"event": "recording", "trial_id"} once the
recorder has started; waits for a line "stop" on stdin; stops the recording, marks the trial recorded,
queues the processing job and prints {"event": "queued", "summary"}.

    python two_host_driver.py BUS_FILE DATA_DIR SIM_JSON
"""

import json
import sys
import time
from pathlib import Path


def main() -> None:
    bus_file, data_dir, sim = Path(sys.argv[1]), Path(sys.argv[2]), json.loads(sys.argv[3])
    from gaitcap.reconstruction.calibration_io import rig_to_toml_text
    from gaitcap.services import catalog as cat
    from gaitcap.services.bus.control import RecorderClient
    from gaitcap.services.bus.session import alive_nodes, load_bus_config, open_session
    from gaitcap.services.processing.artifacts import trial_files
    from gaitcap.simulator import make_trial

    bus = load_bus_config(bus_file)
    rig = make_trial(sim["preset"], seconds=sim["seconds"], cameras=sim["cameras"], seed=sim["seed"], fps=30.0).rig
    session = open_session(bus, None)
    needed = {"recorder", "detector", "worker"}
    deadline = time.monotonic() + 120
    while not needed <= alive_nodes(session, bus):
        if time.monotonic() > deadline:
            raise SystemExit(f"nodes not seen on the bus: {sorted(needed - alive_nodes(session, bus))}")
        time.sleep(0.2)
    db = cat.open_catalog(data_dir / "catalog.sqlite")
    trial = cat.start_trial(db, subject_id="P-netns", session="s1",
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
    reply = recorder.stop(trial.id)
    cat.set_state(db, trial.id, "recorded", stopped_at=time.time(), stage="queued")
    cat.enqueue_job(db, trial.id)
    print(json.dumps({"event": "queued", "trial_id": trial.id, "summary": reply.summary}), flush=True)
    session.close()


if __name__ == "__main__":
    main()
