"""Running the whole stack (real processes, real bus, real SQLite, real uvicorn) inside a test."""

import contextlib
import random
import socket

from services.stack import Stack, StackConfig

TOKEN = "stack-test-token-42"


def _free(port: int) -> bool:
    with socket.socket() as s:
        try:
            s.bind(("127.0.0.1", port))
        except OSError:
            return False
    return True


def free_ports(n: int) -> int:
    """A base port with ``n`` consecutive free ports on 127.0.0.1."""
    for _ in range(200):
        base = random.randrange(20000, 60000 - n)
        if all(_free(base + i) for i in range(n)):
            return base
    raise RuntimeError("no free port range")


@contextlib.contextmanager
def running_stack(tmp_path, **overrides):
    base = free_ports(12)
    values = dict(data_dir=tmp_path / "clinic", token=TOKEN, port=base, bus_base_port=base + 1, cameras=6,
                  size="160x120", sim_seconds=240.0, lease_s=4.0)
    values.update(overrides)
    stack = Stack(StackConfig(**values))
    stack.start(timeout_s=240)
    try:
        yield stack
    finally:
        stack.stop()
