"""The architecture's import rules, every one of them, checked on the source tree.

Layers (the repository's folders, installed as ``gaitcap.<layer>``):
- ``reconstruction`` is pure computation: it imports no other gaitcap layer, no plotting or I/O library,
  and reads and writes no file (the writers of what it computes are ``acquisition.fileio`` /
  ``acquisition.writers``, the readers of what it parses ``acquisition.readers``); one exception, named in
  ``READING_ALLOWED``: the machine's available memory, which is the environment, not data.
- ``acquisition`` (drivers, sync, encoding, detectors, recording) may use ``reconstruction`` only, and its
  simulated camera driver the simulator.
- ``simulator`` (the synthetic world with ground truth) builds on ``acquisition`` and ``reconstruction``
  and never reaches ``services`` or ``api``.
- ``services`` wires them to the bus and never imports ``api``, except ``services.cli``: the one
  composition root that starts the API server.
- ``api`` is HTTP only: it talks to the rest through the catalog, the live-system protocols and a
  trial's files, never to ``acquisition`` (cameras) or to the nodes, research or ops subsystems.
- Inside ``services``: the live nodes know nothing of trial processing, research or operations; the
  catalog knows no other subsystem; trial processing knows neither research nor operations.
- Production code (the live nodes, the API's link to them, the API) never reaches the simulator
  (``simulator``, the simulated camera driver), not even through another module: the
  simulator's hooks live with it (``services.nodes.sim_scene``, wired in by the simulated stack only).
- Rules that hold through any chain of imports (``REACH_RULES``): the API never reaches drivers, detectors,
  the live nodes, research, operations or the trial-processing path, nor the recording reader except
  through the three named modules that need it; a failure names the chain of imports.
- Nothing imports a layer under a generic top-level name (``import services``): always ``gaitcap.``.
- No import cycles between modules (lazy and type-checking imports included).
"""

import ast
import functools
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
LAYERS = ("acquisition", "reconstruction", "services", "api", "simulator")

# (importer prefix, forbidden prefix, exception prefixes of the importer)
RULES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("gaitcap.reconstruction", "gaitcap.acquisition", ()),
    ("gaitcap.reconstruction", "gaitcap.services", ()),
    ("gaitcap.reconstruction", "gaitcap.api", ()),
    ("gaitcap.reconstruction", "gaitcap.simulator", ()),
    ("gaitcap.simulator", "gaitcap.services", ()),
    ("gaitcap.simulator", "gaitcap.api", ()),
    ("gaitcap.api", "gaitcap.simulator", ()),
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


# What a layer may not reach at all, directly or through any chain of imports: (importer prefix, forbidden
# prefix, modules a chain may pass through all the same, each with why). A failure names the chain.
REACH_RULES: tuple[tuple[str, str, tuple[str, ...]], ...] = (
    ("gaitcap.reconstruction", "gaitcap.acquisition", ()),
    ("gaitcap.reconstruction", "gaitcap.services", ()),
    ("gaitcap.reconstruction", "gaitcap.api", ()),
    ("gaitcap.reconstruction", "gaitcap.simulator", ()),
    ("gaitcap.api", "gaitcap.acquisition.drivers", ()),
    ("gaitcap.api", "gaitcap.acquisition.detectors", ()),
    ("gaitcap.api", "gaitcap.acquisition.video_detect", ()),
    ("gaitcap.api", "gaitcap.services.nodes", ()),
    ("gaitcap.api", "gaitcap.services.research", ()),
    ("gaitcap.api", "gaitcap.services.ops", ()),
    ("gaitcap.api", "gaitcap.services.processing.worker", ()),
    ("gaitcap.api", "gaitcap.services.processing.trial", ()),
    # the recording reader: only the live link's crash recovery of a recording (services.live.guard), the
    # patient's still and click on a recorded image (services.processing.people) and a board recording's
    # calibration (services.processing.calibration_job)
    ("gaitcap.api", "gaitcap.acquisition.recording.reader",
     ("gaitcap.services.live.guard", "gaitcap.services.processing.people",
      "gaitcap.services.processing.calibration_job")),
    ("gaitcap.services.catalog", "gaitcap.acquisition", ()),
    ("gaitcap.services.catalog", "gaitcap.services.processing", ()),
    ("gaitcap.services.nodes", "gaitcap.services.processing", ()),
    ("gaitcap.services.nodes", "gaitcap.services.catalog", ()),
    ("gaitcap.services.processing", "gaitcap.services.research", ()),
    ("gaitcap.services.processing", "gaitcap.services.nodes", ()),
    ("gaitcap.services.processing", "gaitcap.services.ops", ()),
)

SIMULATOR = ("gaitcap.simulator", "gaitcap.acquisition.drivers.simulated")
PRODUCTION = ("gaitcap.services.nodes", "gaitcap.services.live", "gaitcap.api")
SIMULATOR_HOOKS = ("gaitcap.services.nodes.sim_scene",)


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


@functools.lru_cache(maxsize=1)
def _tree_graph() -> dict[str, set[str]]:
    """The repository's import graph, built once for the tests that read it."""
    return _graph(_modules())


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


def _reached(graph: dict[str, set[str]], start: str) -> set[str]:
    """Every module ``start`` imports, directly or through others."""
    seen: set[str] = set()
    todo = [start]
    while todo:
        for dep in graph.get(todo.pop(), ()):
            if dep not in seen:
                seen.add(dep)
                todo.append(dep)
    return seen


def _chain(graph: dict[str, set[str]], start: str, target: str, through: tuple[str, ...]) -> list[str] | None:
    """The shortest import chain from ``start`` to a module within ``target`` that passes through none of
    ``through`` (breadth first), or None."""
    previous: dict[str, str | None] = {start: None}
    todo = [start]
    while todo:
        nxt = []
        for name in todo:
            for dep in sorted(graph.get(name, ())):
                if dep in previous or any(_within(dep, t) for t in through):
                    continue
                previous[dep] = name
                if _within(dep, target):
                    chain = [dep]
                    while previous[chain[-1]] is not None:
                        chain.append(previous[chain[-1]])
                    return chain[::-1]
                nxt.append(dep)
        todo = nxt
    return None


def _reach_violations(graph: dict[str, set[str]], rules=REACH_RULES) -> list[str]:
    """``a -> b -> c`` for each module of a ruled layer that reaches what the rule forbids."""
    found = []
    for importer, forbidden, through in rules:
        for name in sorted(n for n in graph if _within(n, importer) and not any(_within(n, t) for t in through)):
            chain = _chain(graph, name, forbidden, through)
            if chain is not None:
                found.append(" -> ".join(chain))
    return found


def _simulator_reached(graph: dict[str, set[str]]) -> list[str]:
    """``production module -> simulator module`` for each production module that reaches the simulator."""
    found = []
    for name in sorted(graph):
        if not any(_within(name, p) for p in PRODUCTION) or any(_within(name, h) for h in SIMULATOR_HOOKS):
            continue
        found += [f"{name} -> {d}" for d in sorted(_reached(graph, name)) if any(_within(d, s) for s in SIMULATOR)]
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
    graph = _tree_graph()
    assert len(graph) > 100, "the layer folders were not found"
    violations = _violations(graph)
    assert not violations, "layer rules broken:\n" + "\n".join(violations)


def test_every_layer_rule_holds_through_any_chain_of_imports():
    violations = _reach_violations(_tree_graph())
    assert not violations, "layers reach what they must not (the chain):\n" + "\n".join(violations)


def test_a_forbidden_reach_is_named_by_its_chain():
    graph = {"gaitcap.api.a": {"gaitcap.services.x"}, "gaitcap.services.x": {"gaitcap.services.y"},
             "gaitcap.services.y": {"gaitcap.acquisition.drivers.video"}, "gaitcap.acquisition.drivers.video": set(),
             "gaitcap.api.b": {"gaitcap.services.ok"}, "gaitcap.services.ok": {"gaitcap.acquisition.drivers.video"}}
    rules = (("gaitcap.api", "gaitcap.acquisition.drivers", ("gaitcap.services.ok",)),)
    assert _reach_violations(graph, rules) == [
        "gaitcap.api.a -> gaitcap.services.x -> gaitcap.services.y -> gaitcap.acquisition.drivers.video"]


def test_no_import_cycles():
    cycles = _cycles(_tree_graph())
    assert not cycles, f"import cycles: {cycles}"


def test_production_code_never_reaches_the_simulator():
    graph = _tree_graph()
    assert "gaitcap.services.nodes.camera" in graph and "gaitcap.services.nodes.sim_scene" in graph
    assert any(_within(d, SIMULATOR[0]) for d in graph["gaitcap.services.nodes.sim_scene"])
    reached = _simulator_reached(graph)
    assert not reached, "the simulator is reached from production code:\n" + "\n".join(reached)


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
    for folder in ("services/nodes", "services/live", "simulator"):
        (tmp_path / folder).mkdir(parents=True, exist_ok=True)
    (tmp_path / "simulator" / "board_scene.py").write_text("")
    (tmp_path / "services" / "live" / "helper.py").write_text("import gaitcap.simulator.board_scene\n")
    (tmp_path / "services" / "nodes" / "camera.py").write_text("from gaitcap.services.live import helper\n")
    (tmp_path / "services" / "nodes" / "sim_scene.py").write_text("import gaitcap.simulator.board_scene\n")
    assert _simulator_reached(_graph(_modules(tmp_path))) == [
        "gaitcap.services.live.helper -> gaitcap.simulator.board_scene",
        "gaitcap.services.nodes.camera -> gaitcap.simulator.board_scene"]


IO_LIBRARIES = {"matplotlib", "zenoh", "mcap", "mcap_protobuf", "fastapi", "starlette", "sqlalchemy", "uvicorn",
                "rerun", "opensim", "PIL", "tempfile", "shutil"}
# method calls that write, move or delete files (np.savez, Path.write_text, fig.savefig, json.dump, ...)
WRITING_CALLS = {"savez", "savez_compressed", "save", "savetxt", "savefig", "write_text", "write_bytes", "mkdir",
                 "makedirs", "dump", "mkstemp", "NamedTemporaryFile", "touch", "unlink", "rmdir"}
OS_WRITING_CALLS = {"replace", "rename", "remove", "unlink", "makedirs", "mkdir", "rmdir"}


def _opens_for_writing(call: ast.Call) -> bool:
    """``open(path, "w")``, ``Path.open("wb")``, ``open(path, mode="a")``: a mode with w, a, x or +."""
    func = call.func
    if isinstance(func, ast.Name) and func.id == "open":
        mode = call.args[1] if len(call.args) > 1 else None
    elif isinstance(func, ast.Attribute) and func.attr == "open":
        mode = call.args[0] if call.args else None
    else:
        return False
    mode = next((k.value for k in call.keywords if k.arg == "mode"), mode)
    return isinstance(mode, ast.Constant) and isinstance(mode.value, str) and bool(set(mode.value) & set("wax+"))


def _calls(path: Path):
    """(call node, called name) of every call in the file: ``f(...)`` -> f, ``x.f(...)`` -> f."""
    for node in ast.walk(ast.parse(path.read_text(), filename=str(path))):
        if isinstance(node, ast.Call):
            func = node.func
            yield node, func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", "")


def _file_writes(path: Path) -> list[str]:
    """``file:line call`` of every call in the file that writes, moves or deletes a file."""
    found = []
    for node, name in _calls(path):
        func = node.func
        on_os = isinstance(func, ast.Attribute) and isinstance(func.value, ast.Name) and func.value.id == "os"
        if (name in WRITING_CALLS or (on_os and name in OS_WRITING_CALLS) or _opens_for_writing(node)):
            found.append(f"{path.name}:{node.lineno} {name}()")
    return found


def test_reconstruction_writes_no_file():
    files = sorted((ROOT / "reconstruction").rglob("*.py"))
    assert len(files) > 50
    writes = [w for p in files for w in _file_writes(p)]
    assert not writes, f"reconstruction must stay pure: write files in acquisition/ or services/: {writes}"
    assert not (ROOT / "reconstruction" / "fileio.py").exists()


def test_file_writes_are_found(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("import os, json\nimport numpy as np\n"
                      "np.savez(f, a=1)\nopen(p, 'wb')\nopen(p)\nopen(p, mode='a')\np.write_text('x')\n"
                      "os.replace(a, b)\ns.replace('a', 'b')\njson.dump(d, f)\njson.dumps(d)\np.open('w')\n")
    assert _file_writes(source) == ["m.py:3 savez()", "m.py:4 open()", "m.py:6 open()", "m.py:7 write_text()",
                                    "m.py:8 replace()", "m.py:10 dump()", "m.py:12 open()"]


# calls that read a file (open(p), Path.read_text, np.load, json.load, tomllib.load, cv2.imread, pd.read_csv,
# ...; csv.reader on a file is found by the open() that gives it the file)
READING_CALLS = {"read_text", "read_bytes", "load", "loadtxt", "genfromtxt", "fromfile", "memmap", "imread",
                 "imreadmulti", "VideoCapture", "File", "listdir", "scandir", "iterdir", "glob", "rglob", "walk"}
READING_PREFIXES = ("read_",)  # pd.read_csv, pd.read_parquet, imageio.v3.imread's read_...
# ``reconstruction/fits/memory.py`` reads /proc/meminfo and the cgroup memory files: the machine's available
# memory (the environment the fit runs in, to size its batches), not data; the one reading module allowed.
READING_ALLOWED = {"fits/memory.py"}


def _file_reads(path: Path) -> list[str]:
    """``file:line call`` of every call in the file that opens, reads or lists a file or folder."""
    return [f"{path.name}:{node.lineno} {name}()" for node, name in _calls(path)
            if name in READING_CALLS or name.startswith(READING_PREFIXES) or name == "open"]


def test_reconstruction_reads_no_file():
    root = ROOT / "reconstruction"
    files = sorted(root.rglob("*.py"))
    assert len(files) > 50
    assert all((root / a).is_file() for a in READING_ALLOWED), "an allowed module is gone: drop it from the list"
    reads = [r for p in files if p.relative_to(root).as_posix() not in READING_ALLOWED for r in _file_reads(p)]
    assert not reads, f"reconstruction must stay pure: read files in acquisition/ (readers.py): {reads}"
    assert _file_reads(root / "fits" / "memory.py"), "memory.py reads no file any more: drop the exception"


def test_file_reads_are_found(tmp_path):
    source = tmp_path / "m.py"
    source.write_text("import json, csv, tomllib\nimport numpy as np\nimport pandas as pd\n"
                      "open(p)\np.read_text()\nnp.load(p)\njson.load(f)\njson.loads(s)\ntomllib.load(f)\n"
                      "tomllib.loads(s)\ncsv.reader(io.StringIO(s))\ncv2.imread(p)\npd.read_csv(p)\n"
                      "np.loadtxt(p)\nh5py.File(p)\np.open()\nnp.frombuffer(b)\nreader.line_num\n")
    assert _file_reads(source) == ["m.py:4 open()", "m.py:5 read_text()", "m.py:6 load()", "m.py:7 load()",
                                   "m.py:9 load()", "m.py:12 imread()", "m.py:13 read_csv()",
                                   "m.py:14 loadtxt()", "m.py:15 File()", "m.py:16 open()"]


def test_reconstruction_uses_no_io_library():
    """Pure computation: no plotting, bus, recording, web, database, viewer or engine library (OpenCV's
    calibration and geometry functions are maths and allowed)."""
    files = sorted((ROOT / "reconstruction").rglob("*.py"))
    offenders = {str(p.relative_to(ROOT)): sorted(_top_level_imports(p) & IO_LIBRARIES) for p in files}
    offenders = {k: v for k, v in offenders.items() if v}
    assert not offenders, f"reconstruction must stay pure: {offenders}"
