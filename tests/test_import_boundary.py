"""The architecture's import rules, every one of them, checked on the source tree.

Layers (the repository's folders, installed as ``gaitcap.<layer>``):
- ``reconstruction`` is pure computation: it imports no other gaitcap layer.
- ``acquisition`` (drivers, sync, encoding, detectors, recording) may use ``reconstruction`` only.
- ``services`` wires them to the bus and never imports ``api``, except ``services.cli``: the one
  composition root that starts the API server.
- ``api`` is HTTP only: it talks to the rest through the catalog, the live-system protocols and a
  trial's files, never to ``acquisition`` (cameras) or to the nodes, research or ops subsystems.
- Inside ``services``: the live nodes know nothing of trial processing, research or operations; the
  catalog knows no other subsystem; trial processing knows neither research nor operations.
- Nothing imports a layer under a generic top-level name (``import services``): always ``gaitcap.``.
- No import cycles between modules (lazy and type-checking imports included).
"""

import ast
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("acquisition", "reconstruction", "services", "api")

# (importer prefix, forbidden prefix, exception prefixes of the importer)
RULES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("gaitcap.reconstruction", "gaitcap.acquisition", ()),
    ("gaitcap.reconstruction", "gaitcap.services", ()),
    ("gaitcap.reconstruction", "gaitcap.api", ()),
    ("gaitcap.acquisition", "gaitcap.services", ()),
    ("gaitcap.acquisition", "gaitcap.api", ()),
    ("gaitcap.services", "gaitcap.api", ("gaitcap.services.cli",)),
    ("gaitcap.api", "gaitcap.acquisition", ()),
    ("gaitcap.api", "gaitcap.services.nodes", ()),
    ("gaitcap.api", "gaitcap.services.research", ()),
    ("gaitcap.api", "gaitcap.services.ops", ()),
    ("gaitcap.api", "gaitcap.services.cli", ()),
    ("gaitcap.services.nodes", "gaitcap.services.processing", ()),
    ("gaitcap.services.nodes", "gaitcap.services.research", ()),
    ("gaitcap.services.nodes", "gaitcap.services.ops", ()),
    ("gaitcap.services.nodes", "gaitcap.services.catalog", ()),
    ("gaitcap.services.catalog", "gaitcap.services.nodes", ()),
    ("gaitcap.services.catalog", "gaitcap.services.processing", ()),
    ("gaitcap.services.catalog", "gaitcap.services.research", ()),
    ("gaitcap.services.catalog", "gaitcap.services.ops", ()),
    ("gaitcap.services.catalog", "gaitcap.services.live", ()),
    ("gaitcap.services.processing", "gaitcap.services.research", ()),
    ("gaitcap.services.processing", "gaitcap.services.ops", ()),
    ("gaitcap.services.processing", "gaitcap.services.nodes", ()),
    ("gaitcap.services.research", "gaitcap.services.nodes", ()),
    ("gaitcap.services.research", "gaitcap.services.ops", ()),
    ("gaitcap.services.bus", "gaitcap.services.nodes", ()),
    ("gaitcap.services.bus", "gaitcap.services.processing", ()),
)


def _module_name(path: Path, root: Path) -> str:
    parts = list(path.relative_to(root).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts = parts[:-1]
    return "gaitcap." + ".".join(parts)


def _raw_imports(path: Path, module: str) -> set[str]:
    """Every dotted name imported by the file (absolute; relative imports resolved; lazy ones too)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    package = module if path.name == "__init__.py" else module.rsplit(".", 1)[0]
    names: set[str] = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            names.update(a.name for a in node.names)
        elif isinstance(node, ast.ImportFrom):
            base = node.module or ""
            if node.level:
                up = package.split(".")[: len(package.split(".")) - (node.level - 1)]
                base = ".".join(up + ([node.module] if node.module else []))
            names.add(base)
            names.update(f"{base}.{a.name}" for a in node.names)
    return names


def _modules(root: Path = ROOT) -> dict[str, Path]:
    return {_module_name(p, root): p for layer in LAYERS for p in sorted((root / layer).rglob("*.py"))}


def _graph(modules: dict[str, Path]) -> dict[str, set[str]]:
    """Module -> the gaitcap modules it imports (names resolved to the longest existing module)."""
    graph = {}
    for name, path in modules.items():
        deps = set()
        for imported in _raw_imports(path, name):
            while imported and imported not in modules:
                imported = imported.rpartition(".")[0]
            if imported and imported != name:
                deps.add(imported)
        graph[name] = deps
    return graph


def _within(name: str, prefix: str) -> bool:
    return name == prefix or name.startswith(prefix + ".")


def _violations(graph: dict[str, set[str]]) -> list[str]:
    found = []
    for importer, deps in graph.items():
        for src, forbidden, exceptions in RULES:
            if not _within(importer, src) or any(_within(importer, e) for e in exceptions):
                continue
            found += [f"{importer} -> {d}" for d in sorted(deps) if _within(d, forbidden)]
    return found


def _cycles(graph: dict[str, set[str]]) -> list[list[str]]:
    """Strongly connected components of more than one module (iterative Tarjan)."""
    index: dict[str, int] = {}
    low: dict[str, int] = {}
    stack: list[str] = []
    on_stack: set[str] = set()
    components = []
    for start in graph:
        if start in index:
            continue
        work = [(start, iter(sorted(graph[start])))]
        index[start] = low[start] = len(index)
        stack.append(start)
        on_stack.add(start)
        while work:
            node, children = work[-1]
            child = next(children, None)
            if child is None:
                work.pop()
                if work:
                    low[work[-1][0]] = min(low[work[-1][0]], low[node])
                if low[node] == index[node]:
                    component = []
                    while True:
                        top = stack.pop()
                        on_stack.discard(top)
                        component.append(top)
                        if top == node:
                            break
                    if len(component) > 1:
                        components.append(sorted(component))
            elif child not in index:
                index[child] = low[child] = len(index)
                stack.append(child)
                on_stack.add(child)
                work.append((child, iter(sorted(graph.get(child, ())))))
            elif child in on_stack:
                low[node] = min(low[node], index[child])
    return components


def _top_level_imports(path: Path) -> set[str]:
    """First names of every absolute import in the file (``numpy`` for ``from numpy.linalg import x``)."""
    tree = ast.parse(path.read_text(), filename=str(path))
    found = set()
    for node in ast.walk(tree):
        if isinstance(node, ast.Import):
            found.update(a.name.split(".")[0] for a in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module.split(".")[0])
    return found


def _generic_imports(path: Path) -> set[str]:
    return _top_level_imports(path) & set(LAYERS)


def test_every_layer_rule_holds():
    graph = _graph(_modules())
    assert len(graph) > 100, "the layer folders were not found"
    violations = _violations(graph)
    assert not violations, "layer rules broken:\n" + "\n".join(violations)


def test_no_import_cycles():
    cycles = _cycles(_graph(_modules()))
    assert not cycles, f"import cycles: {cycles}"


def test_nothing_imports_a_generic_top_level_name():
    files = [p for d in (*LAYERS, "tests", "bench") for p in sorted((ROOT / d).rglob("*.py"))]
    offenders = {str(p.relative_to(ROOT)): sorted(_generic_imports(p)) for p in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert not offenders, f"import the layers as gaitcap.<layer>: {offenders}"


def test_checks_detect_violations_and_cycles(tmp_path):
    for layer in LAYERS:
        (tmp_path / layer).mkdir()
    (tmp_path / "reconstruction" / "a.py").write_text("from gaitcap.services.bus import keys\n")
    (tmp_path / "services" / "bus.py").write_text("import gaitcap.services.worker\n")
    (tmp_path / "services" / "worker.py").write_text("from gaitcap.services import bus\nimport api.app\n")
    graph = _graph(_modules(tmp_path))
    assert _violations(graph) == ["gaitcap.reconstruction.a -> gaitcap.services.bus"]
    assert _cycles(graph) == [["gaitcap.services.bus", "gaitcap.services.worker"]]
    assert _generic_imports(tmp_path / "services" / "worker.py") == {"api"}


IO_LIBRARIES = {"matplotlib", "zenoh", "mcap", "mcap_protobuf", "fastapi", "starlette", "sqlalchemy", "uvicorn",
                "rerun", "opensim", "PIL"}


def test_reconstruction_uses_no_io_library():
    """Pure computation: no plotting, bus, recording, web, database, viewer or engine library (OpenCV's
    calibration and geometry functions are maths and allowed)."""
    files = sorted((ROOT / "reconstruction").rglob("*.py"))
    offenders = {str(p.relative_to(ROOT)): sorted(_top_level_imports(p) & IO_LIBRARIES) for p in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert not offenders, f"reconstruction must stay pure: {offenders}"
