"""share_path: the one way to name a file that deploy/bootstrap.sh installs under <venv>/share/gaitcap/."""

import sys
from pathlib import Path

from gaitcap.acquisition.installed import share_path


def test_default_is_under_the_venv_share_folder(monkeypatch):
    monkeypatch.delenv("GAITCAP_TEST_SHARE_OVERRIDE", raising=False)
    expected = Path(sys.prefix) / "share" / "gaitcap" / "testdata" / "x.mp4"
    assert share_path("testdata", "x.mp4") == expected
    assert share_path("testdata", "x.mp4", env="GAITCAP_TEST_SHARE_OVERRIDE") == expected


def test_a_set_variable_overrides_and_an_empty_one_does_not(monkeypatch, tmp_path):
    monkeypatch.setenv("GAITCAP_TEST_SHARE_OVERRIDE", str(tmp_path / "models"))
    assert share_path("opensim", env="GAITCAP_TEST_SHARE_OVERRIDE") == tmp_path / "models"
    monkeypatch.setenv("GAITCAP_TEST_SHARE_OVERRIDE", "")
    assert share_path("opensim", env="GAITCAP_TEST_SHARE_OVERRIDE") == Path(sys.prefix, "share", "gaitcap", "opensim")
