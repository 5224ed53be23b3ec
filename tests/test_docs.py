"""The manuals stay true: every CLI command and every REST route is documented in docs/, README is short."""

import re
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
ROUTE = re.compile(r"@\w+\.(get|post|put|patch|delete|websocket)\(\s*\"([^\"]+)\"")


def _docs_text() -> str:
    return "\n".join(p.read_text() for p in sorted((ROOT / "docs").glob("*.md")))


def _cli_commands() -> list[str]:
    from gaitcap.services.cli import app

    names = [c.name or c.callback.__name__.replace("_", "-") for c in app.registered_commands]
    for group in app.registered_groups:
        sub = group.typer_instance
        names += [f"{group.name} {c.name or c.callback.__name__.replace('_', '-')}" for c in sub.registered_commands]
    return sorted(names)


def _routes() -> list[tuple[str, str]]:
    """(method, path) of every route declared in api/ (routers carry no prefix: checked here)."""
    routes = []
    for path in sorted((ROOT / "api").rglob("*.py")):
        text = path.read_text()
        assert "APIRouter(prefix" not in text.replace(" ", ""), f"{path.name}: a router prefix; extend this test"
        routes += [(m.upper(), p) for m, p in ROUTE.findall(text)]
    return routes


def _documented(path: str, docs: str) -> bool:
    """A route path is documented when it appears with its parameters written in any way (``{id}``,
    ``TRIAL_ID``, ``cam03``), followed by a space, quote, query, backtick or end of line."""
    if path == "/":
        return True
    pattern = re.escape(path)
    pattern = re.sub(r"\\\{[^}]*\\\}", r"[^/\\s`'\"]+", pattern)
    return re.search(pattern + r"(?=[\s`'\"?)]|$)", docs, flags=re.M) is not None


def test_every_cli_command_is_documented():
    commands = _cli_commands()
    assert len(commands) >= 10, commands
    cli_doc = (ROOT / "docs" / "cli.md").read_text()
    missing = [c for c in commands if f"gaitcap {c}" not in cli_doc and f"`{c}`" not in cli_doc]
    assert not missing, f"commands not in docs/cli.md: {missing}"


def test_every_rest_route_is_documented():
    routes = _routes()
    assert len(routes) >= 20, routes
    docs = _docs_text()
    missing = sorted({f"{m} {p}" for m, p in routes if not _documented(p, docs)})
    assert not missing, f"routes not documented in docs/: {missing}"


@pytest.mark.parametrize("path, ok", [("/trials/{trial_id}/gait", True), ("/trials/{trial_id}/nothing", False)])
def test_route_check_can_fail(path, ok):
    assert _documented(path, "curl $U/trials/TRIAL_ID/gait ") is ok


def test_readme_is_short_and_links_only_existing_docs():
    readme = (ROOT / "README.md").read_text()
    assert len(readme.splitlines()) < 250
    links = re.findall(r"\]\((docs/[^)]+)\)", readme)
    assert links and all((ROOT / link).is_file() for link in links), links
