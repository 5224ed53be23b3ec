"""The catalog backup opens the catalog read-only by a quoted file URI: a data folder whose name holds
URI characters (``?``, ``#``, ``%``) is backed up, not refused nor mistaken for another file."""

import sqlite3

import pytest
from gaitcap.api.backups import backup_sqlite


@pytest.mark.parametrize("folder", ["data?mode=rwc", "lab #2", "100% gait", "a%3Fb"])
def test_a_catalog_in_a_folder_with_uri_characters_is_backed_up(tmp_path, folder):
    src = tmp_path / folder / "catalog.sqlite"
    src.parent.mkdir()
    with sqlite3.connect(src) as db:
        db.execute("CREATE TABLE trials (id TEXT)")
        db.execute("INSERT INTO trials VALUES ('T1')")
    db.close()
    before = sorted(p.name for p in tmp_path.rglob("*"))
    dest = backup_sqlite(src, tmp_path / "backups", keep=2)
    with sqlite3.connect(dest) as copy:
        assert [r[0] for r in copy.execute("SELECT id FROM trials")] == ["T1"]
    copy.close()
    after = sorted(p.name for p in tmp_path.rglob("*") if "backups" not in p.parts)
    assert after == [n for n in before if n != "backups"]  # nothing created beside the catalog
