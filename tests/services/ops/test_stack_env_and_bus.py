"""What each stack child is given (environment) and the stack's bus on its defaults, without starting it."""

import stat

import pytest
from gaitcap.services.ops.child_env import child_environment, held_secrets, is_secret_name
from gaitcap.services.ops.stack import (
    STACK_CLIENT,
    StackConfig,
    bus_config,
    make_stack_bus_keys,
    process_specs,
)

TOKEN = "stack-env-test-password"
PARENT = {"PATH": "/usr/bin", "HOME": "/home/lab", "LANG": "C.UTF-8", "LC_ALL": "C", "PYTHONPATH": "/x",
          "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false", "GAITCAP_TOKENS": "alice:0123456789abcdefXYZ",
          "GAITCAP_MEDIAPIPE_DIR": "/models", "GAITCAP_NORMS_CSV": "/norms.csv", "AWS_SECRET_ACCESS_KEY": "s3cr3t",
          "GITHUB_TOKEN": "ghp_x", "SSH_AUTH_SOCK": "/tmp/agent", "PGPASSWORD": "pw", "JAX_API_KEY": "k",
          "EDITOR": "vim"}


def test_a_child_gets_the_system_its_roles_settings_and_what_the_stack_sets():
    cam = child_environment("camera", PARENT, {"GAITCAP_BUS": "/d/bus.json"})
    assert cam == {"PATH": "/usr/bin", "HOME": "/home/lab", "LANG": "C.UTF-8", "LC_ALL": "C", "PYTHONPATH": "/x",
                   "XLA_FLAGS": "--xla_cpu_multi_thread_eigen=false", "GAITCAP_BUS": "/d/bus.json"}
    api = child_environment("api", PARENT, {})
    assert api["GAITCAP_TOKENS"] == PARENT["GAITCAP_TOKENS"] and "GAITCAP_MEDIAPIPE_DIR" not in api
    assert child_environment("detector", PARENT, {})["GAITCAP_MEDIAPIPE_DIR"] == "/models"
    assert child_environment("worker", PARENT, {})["GAITCAP_NORMS_CSV"] == "/norms.csv"
    for role in ("camera", "detector", "recorder", "worker", "api"):
        env = child_environment(role, PARENT, {})
        assert not {"AWS_SECRET_ACCESS_KEY", "GITHUB_TOKEN", "SSH_AUTH_SOCK", "PGPASSWORD", "JAX_API_KEY",
                    "EDITOR"} & set(env), role
        assert ("GAITCAP_TOKENS" in env) == (role == "api"), role
    assert held_secrets("camera", PARENT) == ["AWS_SECRET_ACCESS_KEY", "GAITCAP_MEDIAPIPE_DIR", "GAITCAP_NORMS_CSV",
                                              "GAITCAP_TOKENS", "GITHUB_TOKEN", "JAX_API_KEY", "PGPASSWORD",
                                              "SSH_AUTH_SOCK"]
    assert is_secret_name("db_password") and not is_secret_name("LC_MONETARY")
    with pytest.raises(ValueError, match="role: 'camera-0' is not one of"):
        child_environment("camera-0", PARENT, {})


def test_every_stack_process_is_given_only_its_roles_environment(tmp_path):
    cfg = StackConfig(data_dir=tmp_path, token=TOKEN, cameras=4, camera_nodes=2, workers=2,
                      extra_env={"GAITCAP_TEST_KNOB": "1"})
    specs = {s.name: s.env for s in process_specs(cfg, epoch_ns=1, parent_env=PARENT)}
    assert sorted(specs) == ["api", "camera-0", "camera-1", "detector", "recorder", "worker-0", "worker-1"]
    for name, env in specs.items():
        assert env["GAITCAP_BUS"] == str(tmp_path.resolve() / "bus.json") and env["GAITCAP_TEST_KNOB"] == "1"
        assert ("GAITCAP_TOKENS" in env) == (name == "api"), name
        assert ("GAITCAP_CATALOG" in env) == (name in ("api", "worker-0", "worker-1")), name
        assert ("GAITCAP_DATA_DIR" in env) == (name in ("api", "recorder", "worker-0", "worker-1")), name
        assert "AWS_SECRET_ACCESS_KEY" not in env and TOKEN not in str(env), name
    assert "GAITCAP_MIN_FPS" in specs["api"]
    assert all("--sim-loop" in s.argv for s in process_specs(cfg, epoch_ns=1) if s.name.startswith("camera"))


def test_the_stacks_bus_is_secured_unless_plain_is_asked_for(tmp_path):
    cfg = StackConfig(data_dir=tmp_path, token=TOKEN, cameras=4, bus_base_port=9000)
    bus = bus_config(cfg)
    assert bus.security is not None and bus.security.keys_dir == tmp_path.resolve() / "bus-keys"
    assert bus.nodes["recorder"] == "tls/127.0.0.1:9000" and all(e.startswith("tls/") for e in bus.nodes.values())
    assert STACK_CLIENT in bus.identities and STACK_CLIENT not in bus.nodes
    made = make_stack_bus_keys(cfg)
    assert sorted(made) == sorted(bus.identities)
    keys = tmp_path / "bus-keys"
    assert stat.S_IMODE(keys.stat().st_mode) == 0o700
    assert all(stat.S_IMODE(f.stat().st_mode) == 0o600 for f in [*keys.glob("*.key"), keys / "passwords.txt"])
    assert make_stack_bus_keys(cfg) == []  # kept at the next start
    plain = bus_config(StackConfig(data_dir=tmp_path, token=TOKEN, cameras=4, bus_base_port=9000, plain_bus=True))
    assert plain.security is None and plain.nodes["recorder"] == "tcp/127.0.0.1:9000"
    assert make_stack_bus_keys(StackConfig(data_dir=tmp_path / "p", token=TOKEN, plain_bus=True)) == []


def test_a_room_on_a_central_catalog_its_api_runs_the_room_and_its_processes_reach_the_catalog(tmp_path, monkeypatch):
    """``gaitcap demo --catalog URL --room NAME`` (the stack) and ``gaitcap serve`` with ``GAITCAP_ROOM``: the
    API runs that room; the API and the workers get the catalog's URL and libpq's password file in their
    environment, never on a command line."""
    from gaitcap.api import server
    from gaitcap.services.cli import app
    from typer.testing import CliRunner

    url = "postgresql+psycopg://gaitcap@db.example/gaitcap?sslmode=verify-full"
    cfg = StackConfig(data_dir=tmp_path, token=TOKEN, cameras=4, workers=2, catalog_url=url, room="gait2")
    specs = {s.name: s for s in process_specs(cfg, epoch_ns=1, parent_env={**PARENT, "PGPASSFILE": "/etc/g/pgpass"})}
    for name in ("api", "worker-0", "worker-1"):
        assert (specs[name].env["GAITCAP_CATALOG"], specs[name].env["PGPASSFILE"]) == (url, "/etc/g/pgpass"), name
    assert not [s.name for s in specs.values() if url in " ".join(s.argv)]
    assert specs["api"].env["GAITCAP_ROOM"] == "gait2"
    served = []
    monkeypatch.setattr(server, "serve", lambda settings, link, scene=None: served.append(settings))
    result = CliRunner().invoke(app, ["serve", "--no-bus", "--data-dir", str(tmp_path)],
                                env={"GAITCAP_ROOM": specs["api"].env["GAITCAP_ROOM"]})
    assert result.exit_code == 0 and served[0].room == "gait2", result.output
