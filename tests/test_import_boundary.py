"""The architecture's one import boundary: reconstruction is pure and imports no other gaitcap layer."""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
FORBIDDEN = {"acquisition", "services", "api"}


def _imports(path: Path) -> set[str]:
    tree = ast.parse(path.read_text(), filename=str(path))
    names = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            names.add(node.module.split(".")[0])
    return names


def test_reconstruction_imports_no_other_layer():
    files = sorted((ROOT / "reconstruction").rglob("*.py"))
    assert files, "reconstruction package not found"
    offenders = {str(f.relative_to(ROOT)): sorted(_imports(f) & FORBIDDEN) for f in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert not offenders, f"reconstruction must not import {sorted(FORBIDDEN)}: {offenders}"


def test_api_does_not_import_acquisition_drivers():
    # api/ is HTTP only: it talks to the rest through services and the catalog, never to cameras.
    files = sorted((ROOT / "api").rglob("*.py"))
    offenders = {str(f.relative_to(ROOT)) for f in files if "acquisition" in _imports(f)}
    assert not offenders, f"api must not import acquisition: {offenders}"


def test_boundary_check_detects_violation(tmp_path):
    bad = tmp_path / "bad.py"
    bad.write_text("from services.bus import keys\nimport api.app\n")
    assert _imports(bad) & FORBIDDEN == {"services", "api"}
