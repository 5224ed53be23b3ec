"""Helpers shared by CLI commands: clean error exits and progress bars."""

from __future__ import annotations

import contextlib
import logging
import sys
from collections.abc import Iterator

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


def progress(total: int | None = None, desc: str = "", unit: str = "it"):
    """A tqdm progress bar on stderr (quiet when stderr is not a terminal)."""
    from tqdm import tqdm

    return tqdm(total=total, desc=desc, unit=unit, file=sys.stderr, disable=None, leave=False)
