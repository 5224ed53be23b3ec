"""Two hosts on one machine: network namespaces joined by a veth pair. The ACQUISITION host runs two
camera nodes (three cameras each); the PROCESSING host runs recorder, detector and worker (and the driver that starts and
stops the trial as the clinic service does). Every Zenoh endpoint is on a veth address, so all frames
and keypoints cross the link. Checks that the trial is recorded (all cameras, keypoints for every
frame) and processed (state done, robust-triangulation gait results in the catalog).

Needs root and ``ip netns`` (skipped with the reason otherwise); the namespaces are deleted even when
the test fails.
"""

import json
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.states import FINISHED

ROOT = Path(__file__).resolve().parents[2]
PY = [sys.executable, "-c", "from gaitcap.services.cli import main; main()"]
SIM = {"preset": "paper", "seconds": 9.0, "cameras": 6, "seed": 5}
SIM_ARGS = ["--sim-preset", SIM["preset"], "--sim-seconds", str(SIM["seconds"]), "--sim-cameras",
            str(SIM["cameras"]), "--sim-seed", str(SIM["seed"]), "--fps", "30"]
FRAMES = 240


@pytest.fixture
def two_hosts():
    """(acq namespace, proc namespace, acq address, proc address); removed afterwards."""
    from gaitcap.simulator import netns

    reason = netns.namespace_unavailable()
    if reason:
        pytest.skip(reason)
    tag = f"{os.getpid() % 100000}"
    acq, proc = f"gcacq{tag}", f"gcproc{tag}"
    subnet = 10 + os.getpid() % 200
    end_a = netns.VethEnd(f"gca{tag}", acq, (f"10.231.{subnet}.1/24",))
    end_p = netns.VethEnd(f"gcp{tag}", proc, (f"10.231.{subnet}.2/24",))
    try:
        for ns in (acq, proc):
            netns.add_namespace(ns, what="two hosts")
        netns.add_veth(end_a, end_p, what="two hosts")
        yield acq, proc, end_a.address, end_p.address
    finally:
        for ns in (acq, proc):
            netns.delete_namespace(ns)
        netns.delete_veth(end_a)  # only if it never left the root namespace


class Processes:
    def __init__(self, log_dir: Path, env: dict) -> None:
        self.log_dir, self.env, self.procs = log_dir, env, {}

    def start(self, name: str, ns: str, argv: list[str], **kwargs) -> subprocess.Popen:
        out = open(self.log_dir / f"{name}.log", "wb")  # noqa: SIM115  (closed with the process)
        from gaitcap.simulator.netns import exec_prefix

        p = subprocess.Popen([*exec_prefix(ns), *argv], env=self.env, cwd=str(ROOT),
                             stdout=kwargs.pop("stdout", out), stderr=out, start_new_session=True, **kwargs)
        self.procs[name] = p
        return p

    def log(self, name: str) -> str:
        return (self.log_dir / f"{name}.log").read_text(errors="replace")[-3000:]

    def stop_all(self) -> None:
        for p in self.procs.values():
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs.values():
            try:
                p.wait(15)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait(5)


def _read_event(proc: subprocess.Popen, expected: str, timeout_s: float) -> dict:
    import selectors

    sel = selectors.DefaultSelector()
    sel.register(proc.stdout, selectors.EVENT_READ)
    deadline = time.monotonic() + timeout_s
    while time.monotonic() < deadline:
        if sel.select(timeout=1.0):
            line = proc.stdout.readline()
            if not line:
                break
            msg = json.loads(line)
            if msg.get("event") == expected:
                return msg
    raise AssertionError(f"driver: no {expected!r} event within {timeout_s} s (exit code {proc.poll()})")


def test_trial_recorded_and_processed_across_two_hosts(tmp_path, two_hosts):
    acq, proc_ns, addr_a, addr_p = two_hosts
    bus_file = tmp_path / "bus.json5"
    bus_file.write_text(json.dumps({"prefix": "gaitcap/netns", "lease_ms": 3000, "insecure_plain": True, "nodes": {
        "camera-0": f"tcp/{addr_a}:7447", "camera-1": f"tcp/{addr_a}:7448",
        "recorder": f"tcp/{addr_p}:7447", "detector": f"tcp/{addr_p}:7448", "worker": f"tcp/{addr_p}:7449"}}))
    data = tmp_path / "data"
    data.mkdir()
    env = dict(os.environ, GAITCAP_BUS=str(bus_file), PYTHONPATH=str(ROOT), PYTHONUNBUFFERED="1")
    procs = Processes(tmp_path, env)
    try:
        procs.start("recorder", proc_ns, [*PY, "node", "recorder", "--node", "recorder", "--flush-s", "0.5",
                                          "--data-dir", str(data)])
        procs.start("detector", proc_ns, [*PY, "node", "detector", "--node", "detector", *SIM_ARGS])
        procs.start("worker", proc_ns, [*PY, "worker", "--node", "worker", "--data-dir", str(data), "--no-refine",
                                        "--no-warm-up", "--lease", "30"])
        driver = procs.start("driver", proc_ns, [sys.executable, str(ROOT / "tests/deploy/two_host_driver.py"),
                                                 str(bus_file), str(data), json.dumps(SIM)],
                             stdin=subprocess.PIPE, stdout=subprocess.PIPE)
        trial_id = _read_event(driver, "recording", 150)["trial_id"]
        start_ns = time.time_ns() + 8_000_000_000  # a synchronised start once the nodes are up
        names = [f"cam{i:02d}" for i in range(1, SIM["cameras"] + 1)]
        half = len(names) // 2
        cameras = [procs.start(f"camera-{k}", acq, [*PY, "node", "camera", "--node", f"camera-{k}", *SIM_ARGS,
                                                    "--cameras", ",".join(part), "--size", "160x120",
                                                    "--frames", str(FRAMES), "--start-at-ns", str(start_ns)])
                   for k, part in enumerate((names[:half], names[half:]))]
        for k, camera in enumerate(cameras):
            assert camera.wait(timeout=150) == 0, procs.log(f"camera-{k}")
        driver.stdin.write(b"stop\n")
        driver.stdin.flush()
        summary = _read_event(driver, "queued", 60)["summary"]
        assert summary["frames"] == SIM["cameras"] * FRAMES, summary
        assert summary["keypoints"] == summary["frames"], summary
        db = cat.open_catalog(data / "catalog.sqlite")
        deadline = time.monotonic() + 180
        while cat.get_trial(db, trial_id).state not in FINISHED and time.monotonic() < deadline:
            time.sleep(0.5)
        trial = cat.get_trial(db, trial_id)
        warnings = cat.warnings_of(cat.get_quality(db, trial_id))
        # the cameras start 8 s after Start and stop after FRAMES frames, before Stop: the trial says so; the
        # only other warning it may carry is the steps check naming a step it did not count (an edge step of
        # the short preliminary pass whose event the detector got wrong)
        assert trial.state == "done_with_warnings", f"{trial.state} {trial.error}\n{procs.log('worker')}"
        assert any(w.startswith("No camera images for") for w in warnings), warnings
        assert all(w.startswith("No camera images for") or " did not count " in w for w in warnings), warnings
        result = cat.get_result(db, trial_id, "preliminary")
        assert result.method == "robust triangulation" and result.quality is not None
        assert len(result.steps) >= 3, (result.steps, result.report)
        from gaitcap.acquisition.recording.reader import read_detections

        det = read_detections(Path(trial.recording_path))
        assert det.shape == (SIM["cameras"], FRAMES, 1, 26)
    finally:
        procs.stop_all()
