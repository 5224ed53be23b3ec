"""gaitcap backup / restore on a small data folder: the backup holds the catalog, the trials' files, the
accounts and the audit trail up to its last whole line, each with its checksum; a damaged backup restores
nothing and names the file; a data folder that is not empty is refused; the restored catalog's paths point
into the new folder; another database is refused with the reason (the CLI says it in one line)."""

import os
import subprocess
import sys

import pytest
from gaitcap.api.audit_chain import AuditChain, verify
from gaitcap.services import catalog as cat
from gaitcap.services.ops.backup import BackupError, restore_backup, take_backup, verify_backup
from gaitcap.services.processing.artifacts import trial_files


def _clinic(data):
    db = cat.open_catalog(data / "catalog.sqlite")
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
                        str(tmp_path / "b"), "--data-dir", str(tmp_path), "--catalog", "postgresql+psycopg://db/x"],
                       capture_output=True, text=True, timeout=60)
    assert r.returncode == 2 and "back it up with its own tools" in r.stderr and "Traceback" not in r.stderr
