"""The deployment files: every Zenoh bus file loads, the multi-host one puts camera nodes on the
acquisition hosts and everything else on the processing host, and every systemd unit's ExecStart is a
valid gaitcap command line (parsed by the CLI itself, with the example environment files) whose bus
node exists in the multi-host bus file."""

import configparser
import re
import shlex
from pathlib import Path

import pytest
import typer.main
from gaitcap.services.bus.session import load_bus_config
from gaitcap.services.cli import app

DEPLOY = Path(__file__).resolve().parents[2] / "deploy"
UNITS = sorted((DEPLOY / "systemd").glob("*.service"))


def _host(endpoint: str) -> str:
    return endpoint.split("/", 1)[1].rsplit(":", 1)[0]


def test_bus_files_load_and_split_acquisition_from_processing():
    files = sorted((DEPLOY / "zenoh").glob("*.json5"))
    assert len(files) >= 3
    for f in files:
        load_bus_config(f)
    bus = load_bus_config(DEPLOY / "zenoh" / "multi-host.json5")
    cameras = {n: _host(e) for n, e in bus.nodes.items() if n.startswith("camera-")}
    others = {_host(e) for n, e in bus.nodes.items() if not n.startswith("camera-")}
    assert len(cameras) >= 3 and len(set(cameras.values())) == len(cameras), "one acquisition host per camera node"
    assert len(others) == 1 and not others & set(cameras.values()), "one processing host"
    assert {"recorder", "detector", "api", "worker-0"} <= set(bus.nodes)


def _env() -> dict[str, str]:
    env = {}
    for name in ("gaitcap.env", "camera-0.env"):
        for line in (DEPLOY / "systemd" / name).read_text().splitlines():
            if line.strip() and not line.lstrip().startswith("#"):
                key, _, value = line.partition("=")
                env[key.strip()] = value.strip()
    return env


def _parse(cmd, args: list[str], parent=None, name: str = "gaitcap"):
    """Parse (without running) a command line; click raises on unknown commands and bad options."""
    ctx = cmd.make_context(name, args, parent=parent)
    if hasattr(cmd, "resolve_command"):  # a group: parse its sub-command
        rest = [*getattr(ctx, "_protected_args", []), *ctx.args]
        sub_name, sub, sub_args = cmd.resolve_command(ctx, rest)
        return _parse(sub, sub_args, ctx, sub_name)
    return ctx


@pytest.mark.parametrize("unit", UNITS, ids=[u.name for u in UNITS])
def test_systemd_units_run_valid_gaitcap_commands(unit):
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.optionxform = str
    parser.read(unit)
    assert {"Unit", "Service", "Install"} <= set(parser.sections())
    assert parser["Service"]["Restart"] == "on-failure"
    exec_start = parser["Service"]["ExecStart"]
    env = _env()
    text = re.sub(r"\$\{(\w+)\}", lambda m: env[m.group(1)], exec_start).replace("%i", "0").replace("%H", "host")
    argv = shlex.split(text)
    assert argv[0] == "/opt/gaitcap/.venv/bin/gaitcap"
    ctx = _parse(typer.main.get_command(app), argv[1:])
    node = ctx.params["node"]
    assert node in load_bus_config(DEPLOY / "zenoh" / "multi-host.json5").nodes, node
    assert ctx.params["bus"] is not None


def test_the_clinic_worker_completes_every_trial_with_the_live_detectors_kind():
    env = _env()
    unit = DEPLOY / "systemd" / "gaitcap-worker@.service"
    parser = configparser.ConfigParser(strict=False, interpolation=None)
    parser.read(unit)
    text = re.sub(r"\$\{(\w+)\}", lambda m: env[m.group(1)], parser["Service"]["ExecStart"])
    ctx = _parse(typer.main.get_command(app), shlex.split(text.replace("%i", "0").replace("%H", "host"))[1:])
    assert ctx.params["complete_with"] == env["GAITCAP_DETECTOR"] != "none"
    assert env["GAITCAP_DETECTOR_PARAM"] == f"model_path={ctx.params['complete_model']}"
    assert ctx.params["complete_only_missing"] is False  # every recorded frame detected again: no live luck
