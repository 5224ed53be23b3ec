"""The clinic stack on fake GigE Vision cameras (``StackConfig(gige=True)``, ``gaitcap demo --gige``): three
``arv-fake-gv-camera-0.8`` processes behind a veth link (jumbo frames) in a network namespace, driven from
this host by the camera process through the Aravis driver; detector, recorder, worker and API as in the
demo. A short trial is recorded through the API and processed (it holds the whole looping walk, so every
camera sees the walker whenever it starts: in the 5 s walk 3 cameras do; with 2, cam01 never does). The
fake cameras film a test pattern with nobody in it, so the keypoints come from the simulated detector (by
camera and frame id): this checks acquisition over the protocol, the bus, recording and processing, not
detection. Skipped, with the reason, where Aravis, the fake camera or network namespaces are missing.
"""

import time
from pathlib import Path

import pytest
from gaitcap.services.ops.stack import Stack, StackConfig, gige_unavailable, process_specs

TOKEN = "stack-gige-test-password"
FPS = 15.0
NAMES = ("cam01", "cam02", "cam03")
WALK_S = 5.0  # the simulated walk loops every 5 s: a trial a little longer holds all of it, whenever it starts


def _arg(argv: tuple[str, ...], flag: str) -> str | None:
    return argv[argv.index(flag) + 1] if flag in argv else None


def test_gige_camera_processes_drive_the_fake_cameras_on_one_frame_count():
    cfg = StackConfig(token=TOKEN, cameras=3, camera_nodes=2, gige=True)
    devices = {"cam01": "10.232.5.11", "cam02": "10.232.5.12", "cam03": "10.232.5.13"}
    specs = {s.name: s for s in process_specs(cfg, epoch_ns=777, devices=devices)}
    argv = specs["camera-0"].argv
    assert (_arg(argv, "--source"), _arg(argv, "--cameras"), _arg(argv, "--devices")) == (
        "aravis", "cam01,cam03", "10.232.5.11,10.232.5.13")
    assert _arg(specs["camera-1"].argv, "--devices") == "10.232.5.12"
    # every camera process (and a restarted one) counts frame periods from the stack's start
    assert {_arg(specs[n].argv, "--start-at-ns") for n in ("camera-0", "camera-1")} == {"777"}
    assert "--cycle-epoch-ns" not in argv and "--sim-loop" not in argv
    with pytest.raises(ValueError, match=r"gige: no GigE Vision device address for cameras \['cam02'\]"):
        process_specs(cfg, epoch_ns=1, devices={"cam01": "10.232.5.11", "cam03": "10.232.5.13"})


def test_where_namespaces_cannot_be_made_the_stack_refuses_saying_why(tmp_path, monkeypatch):
    if gige_unavailable():
        pytest.skip(gige_unavailable())
    monkeypatch.setattr("os.geteuid", lambda: 1000)  # as a user without root
    cfg = StackConfig(data_dir=tmp_path / "clinic", token=TOKEN, cameras=2, gige=True, plain_bus=True)
    stack = Stack(cfg)
    with pytest.raises(ValueError, match=r"^gige: fake GigE Vision cameras cannot run here: the fake cameras' "
                                         r"network namespace: needs root to create network namespaces$"):
        stack.start()
    assert stack.gige_lab is None and not stack.supervisor.children, "nothing may be started"


def test_a_trial_on_the_stack_with_fake_gige_cameras(tmp_path):
    reason = gige_unavailable()
    if reason:
        pytest.skip(reason)
    from gaitcap.acquisition.recording.reader import read_image_times, read_keypoints, read_status
    from gaitcap.services import catalog as cat
    from gaitcap.services.bus.session import free_loopback_ports
    from gaitcap.services.ops.auto_trial import WaitLimits, run_trial

    base = free_loopback_ports(8)[0]
    cfg = StackConfig(data_dir=tmp_path / "clinic", token=TOKEN, port=base, bus_base_port=base + 1, cameras=len(NAMES),
                      fps=FPS, sim_seconds=WALK_S, refine=False, gige=True)
    t0 = time.monotonic()
    with Stack(cfg) as stack:
        lab = stack.gige_lab
        assert stack.devices == dict(zip(NAMES, lab.addresses, strict=True))
        with stack.client() as c:
            t = run_trial(c, subject_id="GIGE001", seconds=WALK_S + 0.5, limits=WaitLimits(stall_s=120, overall_s=240))
        namespace = lab.namespace
    took_s = time.monotonic() - t0
    assert t.state in ("done", "done_with_warnings"), (t.state, t.error, t.warnings)
    db = cat.open_catalog(cfg.catalog)
    path = Path(cat.get_trial(db, t.trial_id).recording_path)
    statuses = read_status(path)
    for cam in NAMES:
        last = statuses[cam][-1]
        # frames came through the Aravis driver from the fake camera at its address, whole
        assert last["extra"]["model"] == "Fake" and last["extra"]["packet_size_bytes"] == 9000, last
        assert last["extra"]["incomplete"] == 0 and last["error"] is None, last
    times = read_image_times(path)
    kp = read_keypoints(path)
    assert all(len(times[c]) >= WALK_S * FPS for c in NAMES), {c: len(v) for c, v in times.items()}
    for c, cam in enumerate(kp.camera_names):  # keypoints for every image, by its camera timestamp; keypoints
        detected = set(kp.timestamps_ns[c][kp.timestamps_ns[c] >= 0].tolist())  # of a frame whose image came just
        images = set(times[cam].tolist())  # before Start are recorded too (they may overtake their image), no others
        assert images <= detected and all(t < min(images) for t in detected - images), (cam, detected ^ images)
    assert sorted(kp.camera_names) == sorted(NAMES)
    assert cat.get_result(db, t.trial_id, "preliminary").method == "robust triangulation"
    # everything is removed: the fake cameras' namespace and link are gone
    import subprocess

    assert namespace not in subprocess.run(["ip", "netns", "list"], capture_output=True, text=True).stdout
    assert took_s < 240, took_s
