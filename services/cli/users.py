"""``gaitcap user add|list|remove``: the web service's accounts (``DATA_DIR/accounts.json``)."""

from __future__ import annotations

from pathlib import Path

import typer
from gaitcap.services.cli._common import user_errors

user_app = typer.Typer(help="Accounts of the clinic web service (roles: clinician, engineer, researcher, admin).",
                       no_args_is_help=True)
DATA_OPT = typer.Option(Path("runs/clinic"), "--data-dir", envvar="GAITCAP_DATA_DIR", help="The service's data folder.")


def _store(data_dir: Path):
    from gaitcap.services.access.accounts import AccountStore

    return AccountStore(data_dir / "accounts.json")


@user_app.command("add")
def add(name: str = typer.Argument(..., help="User name (lower case)."),
        role: list[str] = typer.Option(..., "--role", help="clinician | engineer | researcher | admin (repeat)."),
        data_dir: Path = DATA_OPT) -> None:
    """Create or replace an account; the password is asked twice (never an argument: process lists)."""
    password = typer.prompt(f"password for {name}", hide_input=True, confirmation_prompt=True)
    with user_errors():
        account = _store(data_dir).set(name, password=password, roles=role)
    typer.echo(f"user {account.name}: {', '.join(account.roles)}")


@user_app.command("list")
def list_users(data_dir: Path = DATA_OPT) -> None:
    """The accounts and their roles."""
    for a in _store(data_dir).list():
        typer.echo(f"{a.name}\t{','.join(a.roles)}")


@user_app.command("remove")
def remove(name: str, data_dir: Path = DATA_OPT) -> None:
    """Remove an account."""
    with user_errors():
        if not _store(data_dir).remove(name):
            raise ValueError(f"user {name}: no such account")
    typer.echo(f"removed {name}")


def register(app: typer.Typer) -> None:
    app.add_typer(user_app, name="user")
