"""A PostgreSQL catalog on a real server (the session's throwaway one): TLS chosen by the URL, passwords in no
URL that is logged, no process listing and no environment, and a backup restored (pg_dump / pg_restore)
holding every row, the job numbering going on after the restored rows."""

import logging
import os
from pathlib import Path

import pytest
from gaitcap.services import catalog as cat
from gaitcap.services.catalog import pg_backup, rooms
from gaitcap.services.catalog.models import Base
from gaitcap.services.catalog.pg_tools import program, shown_url
from sqlalchemy import text, update
from sqlalchemy.engine import make_url

from .conftest import raw_sql


def _ssl_in_use(url: str) -> bool:
    db = cat.open_catalog(url)
    try:
        with db.reading() as s:
            return s.execute(text("SELECT ssl FROM pg_stat_ssl WHERE pid = pg_backend_pid()")).scalar_one()
    finally:
        db.close()


def test_tls_to_the_server_is_chosen_in_the_url(postgres, tmp_path):
    from gaitcap.services.bus.certs import web_certificate

    name = "tls_check"
    postgres.create_database(name)
    assert _ssl_in_use(postgres.url(name, sslmode="verify-full", sslrootcert=str(postgres.ca_file)))
    assert not _ssl_in_use(postgres.url(name, sslmode="disable"))
    web_certificate("127.0.0.1", tmp_path / "other-ca")  # a CA the server's certificate is not signed by
    with pytest.raises(Exception, match="certificate verify failed"):
        cat.open_catalog(postgres.url(name, sslmode="verify-full", sslrootcert=str(tmp_path / "other-ca" / "ca.pem")))


def test_a_password_in_the_url_is_never_logged(postgres, caplog):
    from gaitcap.services.catalog.models import SchemaInfo

    secret = postgres.password()
    url = make_url(postgres.create_database("with_password")).set(password=secret).render_as_string(
        hide_password=False)
    with caplog.at_level(logging.INFO):
        db = cat.open_catalog(url)
        assert "***" in db.shown_url and secret not in db.shown_url and secret not in repr(db.engine.url)
        with db.session() as s:
            s.execute(update(SchemaInfo).where(SchemaInfo.key == "version").values(value="999"))
        db.close()
        with pytest.raises(cat.SchemaMismatch) as refused:
            cat.open_catalog(url)
    assert "999" in str(refused.value) and secret not in str(refused.value)
    assert "passfile" not in caplog.text and "password file" in caplog.text  # the warning says where it belongs
    assert secret not in caplog.text and shown_url(url) in caplog.text


def _process_lines() -> list[str]:
    """Every process's command line, as ``ps`` shows them to any user of the host."""
    lines = []
    for pid in filter(str.isdigit, os.listdir("/proc")):
        try:
            lines.append(Path(f"/proc/{pid}/cmdline").read_bytes().replace(b"\0", b" ").decode(errors="replace"))
        except OSError:
            continue
    return lines


def _filled(url: str) -> cat.Catalog:
    db = cat.open_catalog(url)
    rooms.register_room(db, "gait2", host="room2.clinic")
    cal = cat.add_calibration(db, toml="[cam_0]\nname = 'a'\n", source="test")
    for room in ("", "gait2"):
        t = cat.start_trial(db, subject_id="P1", session="v1", calibration_id=cal, room=room,
                            recording_path_for=lambda tid: f"/d/{tid}.mcap")
        cat.set_state(db, t.id, "recorded", enqueue=True)
        cat.store_result(db, trial_id=t.id, stage="preliminary", method="robust", steps=[
            {"side": "left", "time_s": 1.0, "step_length_mm": 600.0}], summary={"step_length_mm": {
                "mean": 600.0, "sd": 12.5, "unit": "mm"}})
        cat.audit(db, actor="dr_a", action="start", trial_id=t.id, detail=f"subject P1 in {room or 'the room'}")
    return db


def _all_rows(url: str) -> dict[str, list]:
    return {t.name: sorted(map(tuple, raw_sql(url, f"SELECT * FROM {t.name}")), key=repr)
            for t in Base.metadata.sorted_tables}


def test_a_dump_restores_every_row_and_no_password_shows_in_a_process_listing(postgres, tmp_path, monkeypatch):
    secrets = [postgres.password(role) for role in ("gaitcap", "postgres")]
    source = postgres.create_database("backup_source")
    db = _filled(source)
    seen = tmp_path / "seen"
    wrappers = tmp_path / "bin"  # pg_dump and pg_restore as they run: their command lines and environments
    wrappers.mkdir()
    for name in ("pg_dump", "pg_restore"):
        script = wrappers / name
        script.write_text(f'#!/bin/sh\n{{ echo "$0 $*"; env; }} >> {seen}\nexec {program(name)} "$@"\n')
        script.chmod(0o755)
    monkeypatch.setenv("GAITCAP_PG_BIN", str(wrappers))
    dumped = pg_backup.dump(source, tmp_path / "backups" / "catalog.dump")
    target = postgres.create_database("backup_target")
    pg_backup.restore(dumped, target)
    assert _all_rows(target) == _all_rows(source)
    assert sum(len(rows) for rows in _all_rows(target).values()) > 15
    listing = "\n".join(_process_lines())
    assert "postgres" in listing and "pg_restore" in seen.read_text()
    for secret in secrets:
        assert secret not in listing and secret not in seen.read_text()
    assert "PGPASSWORD" not in seen.read_text()
    restored = cat.open_catalog(target)
    before = max(j.id for t in cat.list_trials(restored) for j in cat.jobs_for_trial(restored, t.id))
    trial = cat.list_trials(restored, room="gait2")[0]
    assert cat.enqueue_job(restored, trial.id).id == before + 1  # numbering goes on after the restored rows
    assert [e.detail for e in cat.audit_entries(restored, trial_id=trial.id)] == ["subject P1 in gait2"]
    with pytest.raises(pg_backup.BackupFailed, match="already exists"):  # not into a database that has a catalog
        pg_backup.restore(dumped, target)
    assert len(cat.list_trials(restored)) == 2  # and nothing half-done there
    restored.close()
    db.close()


def test_a_dump_of_a_sqlite_catalog_is_refused(tmp_path):
    with pytest.raises(ValueError, match="not a PostgreSQL URL"):
        pg_backup.dump(str(tmp_path / "c.sqlite"), tmp_path / "x.dump")
