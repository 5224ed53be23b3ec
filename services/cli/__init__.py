"""The ``gaitcap`` command line.

Each sub-command lives in its own module in this package and exposes ``register(app)``; modules are
discovered automatically, so adding a command never touches this file. Heavy imports (JAX, OpenCV,
Zenoh) belong inside the command functions so ``gaitcap --help`` stays fast.
"""

from __future__ import annotations

import importlib
import logging
import os
import pkgutil

import typer

app = typer.Typer(
    name="gaitcap",
    help="Live multicamera markerless gait analysis.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


@app.callback()
def _root(verbose: bool = typer.Option(False, "--verbose", "-v", help="Debug logging.")) -> None:
    os.umask(0o077)  # recordings, catalog, keys, logs: files 0600, folders 0700 (patient data)
    logging.basicConfig(
        level=logging.DEBUG if verbose else logging.INFO,
        format="%(asctime)s %(levelname)s %(name)s: %(message)s",
    )


def _register_all() -> None:
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        if info.name.startswith("_"):
            continue
        module = importlib.import_module(f"{__name__}.{info.name}")
        register = getattr(module, "register", None)
        if register is not None:
            register(app)


_register_all()


def main() -> None:
    app()
