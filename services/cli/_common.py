"""Helpers shared by CLI commands: clean error exits, progress bars, stopping on SIGTERM / SIGINT."""

from __future__ import annotations

import contextlib
import logging
import signal
import sys
import threading
from collections.abc import Callable, Iterator

import typer

log = logging.getLogger("gaitcap")


@contextlib.contextmanager
def user_errors() -> Iterator[None]:
    """Turn ValueError/FileNotFoundError into a one-line message and exit code 2 (no traceback)."""
    try:
        yield
    except (ValueError, FileNotFoundError, KeyError) as exc:
        typer.echo(f"error: {exc}", err=True)
        raise typer.Exit(code=2) from None


def key_values(items: list[str], *, option: str = "--param") -> dict:
    """``KEY=VALUE`` options as a dict, each value parsed as JSON where it is JSON (numbers, booleans,
    lists), else kept as text; ValueError naming the option and the item that is not ``KEY=VALUE``."""
    import json

    out = {}
    for item in items:
        key, sep, value = item.partition("=")
        if not sep or not key:
            raise ValueError(f"{option}: expected KEY=VALUE, got {item!r}")
        try:
            out[key] = json.loads(value)
        except json.JSONDecodeError:
            out[key] = value
    return out


def progress(total: int | None = None, desc: str = "", unit: str = "it"):
    """A tqdm progress bar on stderr (quiet when stderr is not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False)


SIGNAL_POLL_S = 0.2  # how often a process waiting to be stopped looks at its signals


class SignalStop(threading.Event):
    """An event set by SIGTERM / SIGINT. Its :meth:`wait` without a timeout polls: a process-directed signal
    may be delivered to another thread (the bus library runs many), which would not wake a main thread blocked
    in a plain wait, and the signal handler would never run (the process then hangs until SIGKILL)."""

    def wait(self, timeout: float | None = None) -> bool:
        if timeout is not None:
            return super().wait(timeout)
        while not super().wait(SIGNAL_POLL_S):
            pass
        return True


def stop_on_signals(on_signal: Callable[[int], None] | None = None) -> SignalStop:
    """A :class:`SignalStop` set by SIGTERM and SIGINT (then ``on_signal(signum)`` runs, if given)."""
    stop = SignalStop()

    def _handler(signum, _frame) -> None:
        log.info("signal %s: stopping", signum)
        stop.set()
        if on_signal is not None:
            on_signal(signum)

    for sig in (signal.SIGTERM, signal.SIGINT):
        signal.signal(sig, _handler)
    return stop
