"""A regular (non-editable) install: the wheel holds only the gaitcap namespace, and it imports from a
fresh venv with the repository out of sight."""

import shutil
import subprocess
import sys
import sysconfig
import zipfile
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
GENERIC = {"acquisition", "reconstruction", "services", "api", "simulator"}


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("wheel")
    src = tmp_path_factory.mktemp("source")  # a copy, so the build leaves nothing in the checkout
    for name in (*GENERIC, "pyproject.toml", "setup.py", "README.md"):
        copy = shutil.copytree if (ROOT / name).is_dir() else shutil.copy2
        copy(ROOT / name, src / name, **({"ignore": shutil.ignore_patterns("__pycache__")} if copy is shutil.copytree else {}))
    subprocess.run([sys.executable, "-m", "pip", "wheel", "-q", "--no-deps", "-w", str(out), str(src)],
                   check=True, timeout=600)
    (found,) = out.glob("gaitcap-*.whl")
    return found


def test_wheel_installs_nothing_under_a_generic_name(wheel):
    names = zipfile.ZipFile(wheel).namelist()
    tops = {n.split("/")[0] for n in names if not n.split("/")[0].endswith(".dist-info")}
    assert tops == {"gaitcap"}, tops
    assert "gaitcap/api/static/index.html" in names
    assert "gaitcap/reconstruction/camera.py" in names and not GENERIC & tops


def test_wheel_imports_in_a_fresh_venv(wheel, tmp_path):
    venv = tmp_path / "venv"
    subprocess.run([sys.executable, "-m", "venv", "--without-pip", str(venv)], check=True, timeout=120)
    py = venv / "bin" / "python"
    site = Path(subprocess.run([str(py), "-c", "import sysconfig; print(sysconfig.get_paths()['purelib'])"],
                               check=True, capture_output=True, text=True).stdout.strip())
    # the dependencies come from this venv's site-packages (a plain path entry: its .pth files, among them
    # the editable install's finder, are not run); gaitcap itself only from the wheel
    (site / "deps.pth").write_text(sysconfig.get_paths()["purelib"] + "\n")
    subprocess.run([sys.executable, "-m", "pip", "install", "-q", "--no-deps", "--no-index",
                    "--target", str(site), str(wheel)], check=True, timeout=300)
    probe = (
        "import importlib.util, gaitcap.reconstruction.camera as c, gaitcap.services.cli as cli, gaitcap.api.app;"
        f"assert c.__file__.startswith({str(site)!r}), c.__file__;"
        f"assert all(importlib.util.find_spec(n) is None for n in {sorted(GENERIC)!r});"
        "print('ok')"
    )
    result = subprocess.run([str(py), "-I", "-c", probe], cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert result.returncode == 0 and result.stdout.strip() == "ok", result.stderr[-2000:]
    help_run = subprocess.run([str(py), "-I", "-c", "from gaitcap.services.cli import main; main()", "--help"],
                              cwd=tmp_path, capture_output=True, text=True, timeout=300)
    assert help_run.returncode == 0 and "reconstruct" in help_run.stdout, help_run.stderr[-2000:]
