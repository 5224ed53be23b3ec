"""gaitcap backup / restore on a small data folder: the backup holds the catalog, the trials' files, the
accounts and the audit trail up to its last whole line, each with its checksum; a damaged backup restores
nothing and names the file; a data folder that is not empty is refused; the restored catalog's paths point
into the new folder; another database is refused with the reason (the CLI says it in one line). A
PostgreSQL catalog (the session's throwaway server) is backed up with pg_dump while a trial is written, its
password on no command line, in no log and not in the manifest, and restored into an empty database and
data folder: the files as their checksums say, the trials in the states the backup holds, the audit chain
intact."""

import json
import os
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest
from gaitcap.acquisition.fileio import atomic_write_text
from gaitcap.api.audit_chain import AuditChain, verify
from gaitcap.services import catalog as cat
from gaitcap.services.catalog.pg_tools import program
from gaitcap.services.ops.backup import BackupError, restore_backup, sha256_of, take_backup, verify_backup
from gaitcap.services.processing.artifacts import trial_files
from sqlalchemy.engine import make_url


def _clinic(data, url=None, *, half_line=True):
    db = cat.open_catalog(url or data / "catalog.sqlite")
    t = cat.start_trial(db, subject_id="P1", session="s1", recording_path_for=lambda tid: trial_files(data, tid).recording)
    files = trial_files(data, t.id)
    files.root.mkdir(parents=True)
    files.recording.write_bytes(b"\x89MCAP0\r\n" + os.urandom(3000))
    for state in ("stopping", "recorded", "processing", "done"):
        cat.set_state(db, t.id, state)
    cat.store_result(db, trial_id=t.id, stage="preliminary", method="robust", steps=[], summary={})
    gait = files.stage_file("preliminary", "gait_json")
    gait.parent.mkdir()
    gait.write_text('{"steps": []}')
    cat.add_artifacts(db, t.id, "preliminary", {"gait_json": str(gait)})
    db.close()
    (data / "accounts.json").write_text("{}")
    chain = AuditChain(data / "audit.log")
    for k in range(3):
        chain.record(actor="anna", action="get", target=f"/trials/{t.id}", detail=str(k))
    if half_line:
        with open(data / "audit.log", "a") as f:
            f.write('{"at": 1, "half a line')  # being appended while the backup reads it
    (data / "logs").mkdir()
    (data / "logs" / "api.log").write_text("not backed up")
    return t.id


def test_a_backup_is_complete_checked_and_restored_with_its_paths_moved(tmp_path):
    data = tmp_path / "clinic"
    data.mkdir()
    tid = _clinic(data)
    got = take_backup(data, str(data / "catalog.sqlite"), tmp_path / "backup")
    assert got.trials == {tid: "done"}
    assert set(got.files) == {"catalog.sqlite", "accounts.json", "audit.log", f"trials/{tid}/recording.mcap",
                              f"trials/{tid}/preliminary/gait.json"}
    assert verify(tmp_path / "backup" / "audit.log") == (3, None)  # the half line left out
    assert oct((tmp_path / "backup" / "catalog.sqlite").stat().st_mode & 0o777) == "0o600"

    with pytest.raises(BackupError, match="not empty"):
        restore_backup(tmp_path / "backup", data)
    new = tmp_path / "restored"
    restore_backup(tmp_path / "backup", new)
    assert (new / f"trials/{tid}/recording.mcap").read_bytes() == (data / f"trials/{tid}/recording.mcap").read_bytes()
    assert not (new / "logs").exists()
    db = cat.open_catalog(new / "catalog.sqlite", create=False)
    assert cat.get_trial(db, tid).recording_path == str((new / f"trials/{tid}/recording.mcap").resolve())
    assert cat.get_result(db, tid).artifacts["gait_json"].startswith(str(new.resolve()))
    db.close()


def test_a_damaged_backup_restores_nothing_and_names_the_file(tmp_path):
    data = tmp_path / "clinic"
    data.mkdir()
    tid = _clinic(data)
    take_backup(data, str(data / "catalog.sqlite"), tmp_path / "backup")
    rec = tmp_path / "backup" / "trials" / tid / "recording.mcap"
    rec.write_bytes(rec.read_bytes()[:-1] + b"!")
    with pytest.raises(BackupError, match=f"trials/{tid}/recording.mcap differs"):
        restore_backup(tmp_path / "backup", tmp_path / "restored")
    assert not (tmp_path / "restored").exists()
    (tmp_path / "backup" / "manifest.json").unlink()
    with pytest.raises(BackupError, match="no manifest.json"):
        verify_backup(tmp_path / "backup")


def test_the_cli_refuses_another_database_in_one_line(tmp_path):
    r = subprocess.run([sys.executable, "-c", "from gaitcap.services.cli import main; main()", "backup", "--to",
                        str(tmp_path / "b"), "--data-dir", str(tmp_path), "--catalog", "mysql://db/x"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "back it up with its own tools" in r.stderr and "Traceback" not in r.stderr


def _write_trials(url, data, stop, written):
    """A clinic at work: trials recorded (the recording growing as ``.part``, renamed at Stop), processed
    (a result file written atomically) and looked at (audit lines), one after the other until ``stop``."""
    db, chain = cat.open_catalog(url), AuditChain(data / "audit.log")
    while not stop.is_set():
        t = cat.start_trial(db, subject_id="P2", session="s2",
                            recording_path_for=lambda tid: trial_files(data, tid).recording)
        files = trial_files(data, t.id)
        files.root.mkdir(parents=True)
        part = Path(f"{files.recording}.part")
        with open(part, "wb") as f:
            for _ in range(20):
                f.write(os.urandom(4096))
                f.flush()
        part.rename(files.recording)
        for state in ("stopping", "recorded", "processing"):
            cat.set_state(db, t.id, state)
        gait = files.stage_file("preliminary", "gait_json")
        gait.parent.mkdir()
        atomic_write_text(gait, json.dumps({"steps": [], "trial": t.id}))
        cat.store_result(db, trial_id=t.id, stage="preliminary", method="robust", steps=[], summary={})
        cat.add_artifacts(db, t.id, "preliminary", {"gait_json": str(gait)})
        cat.set_state(db, t.id, "done")
        chain.record(actor="anna", action="get", target=f"/trials/{t.id}")
        written.append(t.id)
    db.close()


def _wait_for(condition, what, timeout_s=60.0):
    end = time.monotonic() + timeout_s
    while not condition():
        assert time.monotonic() < end, what
        time.sleep(0.02)


def test_a_postgresql_clinic_backed_up_while_a_trial_is_written_restores_into_an_empty_database(
        postgres, tmp_path, monkeypatch, caplog):
    secret = postgres.password()

    def with_password(name):  # as a careless user might give it
        return make_url(postgres.create_database(name)).set(password=secret).render_as_string(hide_password=False)

    source, target = with_password("clinic_pg"), with_password("restored_pg")
    seen = tmp_path / "seen"
    wrappers = tmp_path / "bin"  # pg_dump and pg_restore as they run: their command lines and environments
    wrappers.mkdir()
    for name in ("pg_dump", "pg_restore"):
        (wrappers / name).write_text(f'#!/bin/sh\n{{ echo "$0 $*"; env; }} >> {seen}\nexec {program(name)} "$@"\n')
        (wrappers / name).chmod(0o755)
    monkeypatch.setenv("GAITCAP_PG_BIN", str(wrappers))
    data = tmp_path / "clinic"
    data.mkdir()
    first = _clinic(data, source, half_line=False)
    stop, written = threading.Event(), []
    writer = threading.Thread(target=_write_trials, args=(source, data, stop, written))
    writer.start()
    try:
        _wait_for(lambda: len(written) >= 1, "the writer finished no trial")
        got = take_backup(data, source, tmp_path / "backup")
        after = len(written)
        _wait_for(lambda: len(written) >= after + 2, "the writer stopped while the backup ran")
    finally:
        stop.set()
        writer.join(60)
    assert "catalog.dump" in got.files and "catalog.sqlite" not in got.files
    assert got.trials[first] == "done" and written[0] in got.trials
    assert written[-1] not in got.trials  # started after a trial that ended after the backup: not in it
    manifest = (tmp_path / "backup" / "manifest.json").read_text()
    assert secret not in manifest and secret not in seen.read_text() and secret not in caplog.text
    assert "pg_dump" in seen.read_text() and "PGPASSWORD" not in seen.read_text()

    with pytest.raises(BackupError, match="holds a PostgreSQL catalog"):
        restore_backup(tmp_path / "backup", tmp_path / "restored")
    new = tmp_path / "restored"
    restore_backup(tmp_path / "backup", new, target)
    assert "pg_restore" in seen.read_text() and secret not in seen.read_text() and secret not in caplog.text
    for rel, (size, digest) in got.files.items():
        if rel != "catalog.dump":
            assert (new / rel).stat().st_size == size and sha256_of(new / rel) == digest, rel
    assert verify(new / "audit.log") == (verify(tmp_path / "backup" / "audit.log")[0], None)
    db = cat.open_catalog(target, create=False)
    assert {t.id: t.state for t in cat.list_trials(db)} == got.trials
    for tid, state in got.trials.items():
        if state == "done":
            assert cat.get_trial(db, tid).recording_path == str((new / f"trials/{tid}/recording.mcap").resolve())
            gait = cat.get_result(db, tid).artifacts["gait_json"]
            assert gait.startswith(str(new.resolve())) and Path(gait).is_file()
    db.close()
    with pytest.raises(BackupError, match="already exists"):  # not into a database that has a catalog
        restore_backup(tmp_path / "backup", tmp_path / "again", target)
    assert not (tmp_path / "again").exists()
