"""The stack on its defaults, as real processes (simulated cameras, detector, recorder, worker, API;
Zenoh on loopback; SQLite): its bus refuses a peer without credentials, no child holds a secret it does
not use, the simulated walk starts over with no pause, and the demo's wait after Stop follows the worker's
stages and says what was still running when the worker is slowed (SIGSTOP / SIGCONT in turn).

One stack serves the module: 4 cameras at 15 fps, a 5 s walk (so it starts over every 5 s), no refined fit.
"""

import os
import signal
import stat
import threading
import time
from pathlib import Path

import pytest
from gaitcap.services.bus.certs import make_bus_keys
from gaitcap.services.bus.control import RecorderClient, RecorderError
from gaitcap.services.bus.messages import ImageFrame, Keypoints
from gaitcap.services.bus.security import BusSecurity
from gaitcap.services.bus.session import BusConfig, alive_nodes, free_loopback_ports, open_session
from gaitcap.services.ops.auto_trial import FINISHED, WaitLimits, start_when_ready, wait_for_results
from gaitcap.services.ops.stack import STACK_CLIENT, Stack, StackConfig

PASSWORD = "defaults-test-password-42"
API_TOKEN = "alice-api-token-0123456789"
CLOUD_SECRET = "cloud-secret-abcdef0123456789"
WALK_S, FPS = 5.0, 15.0
JPEG = bytes.fromhex("ffd8ffe000104a464946") + b"\x00" * 20 + bytes.fromhex("ffd9")
MARK = 987_654_321  # the intruder's frame id


@pytest.fixture(scope="module")
def stack(tmp_path_factory):
    base = free_loopback_ports(12)[0]
    cfg = StackConfig(data_dir=tmp_path_factory.mktemp("defaults") / "clinic", token=PASSWORD, port=base,
                      bus_base_port=base + 1, cameras=4, size="160x120", fps=FPS, sim_seconds=WALK_S, refine=False)
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GAITCAP_TOKENS", f"alice:{API_TOKEN}")
        mp.setenv("CLOUD_SECRET_ACCESS_KEY", CLOUD_SECRET)
        with Stack(cfg) as s:
            yield s


def _wait(cond, timeout_s=10.0):
    end = time.monotonic() + timeout_s
    while time.monotonic() < end:
        if cond():
            return True
        time.sleep(0.05)
    return False


def _descendants(pid: int) -> list[int]:
    children: dict[int, list[int]] = {}
    for f in Path("/proc").glob("[0-9]*/stat"):
        try:
            ppid = int(f.read_text().rsplit(")", 1)[1].split()[1])
        except (OSError, IndexError, ValueError):
            continue
        children.setdefault(ppid, []).append(int(f.parent.name))
    out, todo = [], [pid]
    while todo:
        p = todo.pop()
        out.append(p)
        todo += children.get(p, [])
    return out


def _environ(pid: int) -> dict[str, str]:
    raw = Path(f"/proc/{pid}/environ").read_bytes()
    return dict(item.split("=", 1) for item in raw.decode(errors="replace").split("\0") if "=" in item)


def test_no_child_holds_a_secret_it_does_not_use(stack):
    seen = 0
    for name in stack.supervisor.children:
        for pid in _descendants(stack.supervisor.pid(name)):
            try:
                env = _environ(pid)
            except (FileNotFoundError, ProcessLookupError):
                continue  # a short-lived helper that has gone
            seen += 1
            text = "\0".join(f"{k}={v}" for k, v in env.items())
            assert CLOUD_SECRET not in text and PASSWORD not in text, (name, pid)
            assert (API_TOKEN in text) == (name == "api"), (name, pid)  # the API checks the tokens; no other
            assert env["GAITCAP_BUS"] == str(stack.bus_file), name
            assert ("GAITCAP_CATALOG" in env) == (name == "api" or name.startswith("worker")), name
            assert env["PATH"] == os.environ["PATH"], name
    assert seen >= len(stack.supervisor.children)


def test_the_bus_keys_are_made_private_and_the_bus_file_says_tls(stack):
    keys = stack.data_dir / "bus-keys"
    assert stat.S_IMODE(keys.stat().st_mode) == 0o700
    for f in ("ca.key", "passwords.txt", "recorder.key", f"{STACK_CLIENT}.key"):
        assert stat.S_IMODE((keys / f).stat().st_mode) == 0o600, f
    assert stack.bus.security is not None and all(e.startswith("tls/127.0.0.1:") for e in stack.bus.nodes.values())
    assert '"security"' in stack.bus_file.read_text() and "plain TCP" not in (stack.data_dir / "logs/recorder.log").read_text()


def _intruder(stack, tmp: Path, how: str):
    nodes = stack.bus.nodes
    if how == "plain tcp":
        return open_session(BusConfig({n: e.replace("tls/", "tcp/") for n, e in nodes.items()},
                                      prefix=stack.bus.prefix))
    keys = tmp / "keys"
    if how == "certificate of another CA":
        make_bus_keys({"intruder": None}, keys)
        return open_session(BusConfig(nodes, prefix=stack.bus.prefix, security=BusSecurity(keys, clients=("intruder",))),
                            "intruder")
    keys.mkdir(mode=0o700)  # the stack's client certificate, a wrong password
    for f in ("ca.pem", f"{STACK_CLIENT}.pem", f"{STACK_CLIENT}.key"):
        (keys / f).write_bytes((stack.bus.security.keys_dir / f).read_bytes())
    (keys / "passwords.txt").write_text(f"{STACK_CLIENT}:wrong-password-0123456789\n")
    return open_session(BusConfig(nodes, prefix=stack.bus.prefix, security=BusSecurity(keys, clients=(STACK_CLIENT,))),
                        STACK_CLIENT)


@pytest.mark.parametrize("how", ["plain tcp", "certificate of another CA", "stack certificate, wrong password"])
def test_a_peer_without_credentials_can_do_nothing_on_the_default_stack(stack, tmp_path, how):
    got = []

    def on_any(sample):
        att = b"" if sample.attachment is None else bytes(sample.attachment.to_bytes())
        got.append(bytes(sample.payload.to_bytes()) + att)

    watcher = stack.bus_session()
    sub = watcher.declare_subscriber(f"{stack.bus.prefix}/**", on_any)
    with stack.client() as c:
        trial_id = start_when_ready(c, {"subject_id": "SEC0001"})
        s = _intruder(stack, tmp_path, how)
        try:
            assert not _wait(lambda: list(s.info.peers_zid()), timeout_s=1.5), f"{how}: connected"
            assert alive_nodes(s, stack.bus, timeout_s=0.3) == set()
            client = RecorderClient(s, stack.bus.keys, timeout_s=0.5)
            for ask in (client.status, lambda: client.stop(trial_id),
                        lambda: client.start(trial_id="evil", path="evil.mcap")):
                with pytest.raises(RecorderError, match="no recorder answered"):
                    ask()
            frame = ImageFrame.build(JPEG, camera="cam01", timestamp_ns=1, frame_id=MARK, sent_ns=1)
            s.put(stack.bus.keys.image("cam01"), frame.payload, attachment=frame.meta.to_bytes())
            s.put(stack.bus.keys.keypoints("cam01"), Keypoints("cam01", MARK, 1, "halpe26", [], 1.0).to_bytes())
            time.sleep(1.0)
        finally:
            s.close()
        assert c.get(f"/trials/{trial_id}").json()["state"] == "recording", f"{how}: the trial was stopped"
        c.post(f"/trials/{trial_id}/stop").raise_for_status()
    sub.undeclare()
    watcher.close()
    assert got, "the stack's own client received nothing"
    assert not [g for g in got if str(MARK).encode() in g], f"{how}: a message of the intruder was delivered"


def test_the_simulated_walk_starts_over_with_no_pause(stack):
    frames, people_after_the_end = [], []
    n = int(WALK_S * FPS)

    def on_image(sample):
        f = ImageFrame.from_bytes(bytes(sample.payload.to_bytes()), bytes(sample.attachment.to_bytes()), camera="cam01")
        frames.append((f.meta.frame_id, f.timestamp_ns, time.monotonic()))

    def on_keypoints(sample):
        k = Keypoints.from_bytes(bytes(sample.payload.to_bytes()))
        if k.frame_id >= n:
            people_after_the_end.append(len(k.people))

    session = stack.bus_session()
    subs = [session.declare_subscriber(stack.bus.keys.image("cam01"), on_image),
            session.declare_subscriber(stack.bus.keys.keypoints("cam01"), on_keypoints)]
    restarts = stack.supervisor.restarts("camera-0")
    time.sleep(WALK_S + 2.5)
    for sub in subs:
        sub.undeclare()
    session.close()
    assert stack.supervisor.restarts("camera-0") == restarts, "the camera process exited at the walk's end"
    ids = [f[0] for f in frames]
    assert ids == sorted(ids) and len(ids) >= WALK_S * FPS, ids[:5]
    assert ids[-1] // n > ids[0] // n, f"the walk did not start over in {WALK_S + 2.5} s: ids {ids[0]}..{ids[-1]}"
    period_ns = 1e9 / FPS
    for (i0, t0, _), (i1, t1, _) in zip(frames, frames[1:], strict=False):  # on one frame grid across the end
        assert abs((t1 - t0) - (i1 - i0) * period_ns) < 0.2 * period_ns, (i0, i1, t1 - t0)
    missing = ids[-1] - ids[0] + 1 - len(set(ids))
    assert missing <= 0.05 * len(ids), f"{missing} frame ids missing"
    arrival_gap_s = max(b[2] - a[2] for a, b in zip(frames, frames[1:], strict=False))
    assert arrival_gap_s < 2.0, f"no frames for {arrival_gap_s:.1f} s"
    assert people_after_the_end and max(people_after_the_end) >= 1, "no keypoints past the walk's end"


def _slow_when_processing(stack, subject_id: str, slowed: threading.Event, stop: threading.Event) -> None:
    """Once the trial of ``subject_id`` reports a processing stage, slow the worker down to about 2 % of
    its speed (SIGSTOP, 0.5 s; SIGCONT, 0.01 s; never stopped for long, so a catalog write it holds
    delays the API by at most that), until ``stop``; then let it run."""
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(stack.cfg.catalog, create=False)
    try:
        while not stop.is_set() and not slowed.is_set():
            trials = cat.list_trials(db, subject_id=subject_id, limit=1)
            if trials and trials[0].state == "processing" and trials[0].stage:
                slowed.set()
            time.sleep(0.05)
    finally:
        db.close()
    while not stop.is_set():
        stack.supervisor.kill("worker-0", signal.SIGSTOP)
        stop.wait(0.5)
        stack.supervisor.kill("worker-0", signal.SIGCONT)
        time.sleep(0.01)


def _until_idle(stack, timeout_s: float = 180.0) -> None:
    """Until every trial of the catalog is finished (the worker free for the next)."""
    from gaitcap.services import catalog as cat

    db = cat.open_catalog(stack.cfg.catalog, create=False)
    try:
        assert _wait(lambda: all(t.state in FINISHED for t in cat.list_trials(db)), timeout_s), "trials left running"
    finally:
        db.close()


def test_the_wait_says_what_is_still_running_when_the_worker_is_slowed(stack, capsys):
    """``gaitcap demo --auto``'s trial with the worker slowed mid-stage: it gives up after the limit without
    news, saying the stage and for how long; the same trial, resumed, finishes (slower, not failed)."""
    from gaitcap.services.cli.demo import _one_trial

    _until_idle(stack)
    slowed, stop = threading.Event(), threading.Event()
    slower = threading.Thread(target=_slow_when_processing, args=(stack, "DEMO001", slowed, stop), daemon=True)
    slower.start()
    try:
        ok = _one_trial(stack, seconds=3.0, refine=False, limits=WaitLimits(stall_s=4.0, overall_s=120.0))
    finally:
        stop.set()
        slower.join(5)
        stack.supervisor.kill("worker-0", signal.SIGCONT)
    assert slowed.is_set(), "the worker never reported a stage"
    err = capsys.readouterr().err
    assert not ok
    line = next(x for x in err.splitlines() if x.startswith("trial "))
    assert " processing: gave up: still processing, stage '" in line and "nothing new reported for" in line, line
    assert "s after Stop" in line and "limit 4 s without news" in line and "logs in" in line, line
    trial_id = line.split()[1]
    with stack.client() as c:  # resumed: the same trial finishes, later
        trial, prelim, _, why = wait_for_results(c, trial_id, limits=WaitLimits(stall_s=120.0, overall_s=300.0))
    assert why == "" and trial["state"] in FINISHED and trial["state"] != "failed", trial
    assert prelim is not None

