"""A working day in short, on the stack as real processes (``bench/soak.py --faults``): one trial with each
fault of the schedule (SIGKILL of the detector, recorder, camera process and worker; the worker SIGSTOPped;
the data disk filled to the API's threshold; the API restarted mid-trial) and a trial without one after them.
Every trial ends done, or done with warnings / failed saying why; no recording is lost or orphaned; the
trial after each fault is done; read routes answer within 1 s while the worker is stopped. A backup taken
while the trials run is restored into an empty data folder and served by a fresh API: every file it holds
byte-identical to the clinic's, the audit chain verifies, the trials and their files served."""

import hashlib
import threading
import time
from pathlib import Path

import httpx
import pytest
from gaitcap.api.audit_chain import verify
from gaitcap.api.server import serve_in_thread
from gaitcap.api.settings import Settings
from gaitcap.services.access.client import DEMO_USER, sign_in
from gaitcap.services.bus.session import free_loopback_ports
from gaitcap.services.ops.backup import restore_backup, take_backup, verify_backup
from gaitcap.services.ops.fault_schedule import FAULTS, disk_threshold_env
from gaitcap.services.ops.soak import run_soak
from gaitcap.services.ops.stack import Stack, StackConfig

TOKEN = "soak-test-password-42"
ORDER = ("kill_detector", "fill_disk", "kill_recorder", "restart_api", "kill_camera", "kill_worker", "stop_worker")


def _sha(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


@pytest.mark.timeout(600)  # a stack, 8 trials, restarts, a restore: 50 s on the quiet 2-core machine, 4-8 min at load 30
def test_a_day_with_every_fault_then_a_backup_restored(tmp_path):
    base = free_loopback_ports(12)[0]
    data = tmp_path / "clinic"
    cfg = StackConfig(data_dir=data, token=TOKEN, port=base, bus_base_port=base + 1, cameras=3, size="120x90",
                      fps=10.0, sim_seconds=5.0, refine=False, lease_s=3.0, extra_env=disk_threshold_env(data))
    plan = dict(enumerate(ORDER))  # then a trial without a fault
    assert sorted(plan.values()) == sorted(FAULTS)
    backups = []

    def back_up_while_trials_run():
        while not (data / "trials").is_dir() or len(list((data / "trials").iterdir())) < 3:
            time.sleep(0.5)
        backups.append(take_backup(data, cfg.catalog, tmp_path / "backup"))

    with Stack(cfg) as stack:
        taker = threading.Thread(target=back_up_while_trials_run, daemon=True)
        taker.start()
        report = run_soak(stack, trials=len(ORDER) + 1, every_s=1.0, trial_s=2.0, stall_s=120.0, plan=plan,
                          stop_s=3.0, warm_up=1)
        taker.join(60)
        originals = {p.relative_to(data).as_posix(): _sha(p) for p in (data / "trials").rglob("*") if p.is_file()}
    d = report.to_dict()
    said = [(t.fault, t.state, t.reason[:300], t.gave_up) for t in report.trials]
    by_fault = {t.fault: t for t in report.trials if t.fault}
    assert report.all_ended_with_reason, said
    assert report.recordings_lost == 0 and not report.orphans, (d["trials"], report.orphans)
    for k in plan:  # the next trial processed without anyone acting (or ended by its own fault, saying why)
        after = report.trials[k + 1]
        assert after.state in ("done", "done_with_warnings") or (after.fault and after.reason), (plan[k], said)
    assert "Start refused: data disk" in by_fault["fill_disk"].fault_detail, by_fault["fill_disk"]
    killed = by_fault["kill_recorder"]  # recovered and processed, or (killed before any keypoint) failed saying so
    assert killed.state in ("done_with_warnings", "failed") and "recovered" in killed.reason, said
    assert killed.recording_kept
    assert by_fault["stop_worker"].read_p99_s is not None and by_fault["stop_worker"].read_p99_s < 1.0
    assert set(report.rss_slope_mb_per_trial) == {"recorder", "detector", "camera-0", "worker-0", "api"}

    assert backups, "no backup was taken while the trials ran"
    backup = verify_backup(backups[0].folder)
    restored = tmp_path / "restored"
    restore_backup(backup.folder, restored)
    copied = {rel: digest for rel, (_, digest) in backup.files.items() if rel.startswith("trials/")}
    finished = [tid for tid, state in backup.trials.items() if state in ("done", "done_with_warnings", "failed")]
    assert finished and copied
    for rel, digest in copied.items():
        if rel.split("/")[1] in finished:  # a trial finished in the snapshot is as it was at the end of the day
            assert originals[rel] == digest == _sha(restored / rel), rel
    n, problem = verify(restored / "audit.log")
    assert problem is None and n > 10

    settings = Settings(catalog_url=str(restored / "catalog.sqlite"), data_dir=restored, port=free_loopback_ports(1)[0])
    srv = serve_in_thread(settings, None)
    try:
        with httpx.Client(base_url=srv.url, timeout=10) as client:
            sign_in(client, DEMO_USER, TOKEN)
            served = {t["id"]: t["state"] for t in client.get("/trials", params={"limit": 100}).json()}
            assert {tid: backup.trials[tid] for tid in finished} == {tid: served[tid] for tid in finished}
            for tid in finished:
                rec = client.get(f"/trials/{tid}/recording")
                assert rec.status_code == 200 and hashlib.sha256(rec.content).hexdigest() == copied[
                    f"trials/{tid}/recording.mcap"]
                if backup.trials[tid] != "failed":
                    assert client.get(f"/trials/{tid}/gait").status_code == 200
    finally:
        srv.stop()
