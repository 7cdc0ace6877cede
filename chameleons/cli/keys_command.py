"""``chameleons keys create``: the CURVE keys of the server-worker ZeroMQ link."""

from __future__ import annotations

from pathlib import Path

import click

from chameleons.cli.common import load_settings


@click.group("keys")
def keys() -> None:
    """CURVE keys that authenticate and encrypt the link between server and workers."""


@keys.command("create")
@click.option("--keys-dir", type=click.Path(file_okay=False, path_type=Path), default=None,
              help="Where to write them. [<data dir>/keys; CHAMELEONS_ZMQ_KEYS_DIR]")  # fmt: skip
@click.option(
    "--worker",
    "worker_name",
    default=None,
    help="Name of the worker key pair (one per booth PC, if you like). [worker]",
)
@click.option("--force", is_flag=True, help="Replace an existing key pair of that name.")
def create(keys_dir: Path | None, worker_name: str | None, force: bool) -> None:
    """Create the server's key pair (once) and a worker's, and authorize the worker.
    Copy server.key and the worker's two files to a booth PC's keys folder."""
    from chameleons.worker.curve import CurveError, create_keys

    settings = load_settings()
    folder = keys_dir or settings.keys_dir
    try:
        made = create_keys(folder, worker_name or settings.worker_key_name, force=force)
    except CurveError as exc:
        raise click.ClickException(str(exc)) from exc
    for path in made:
        click.echo(f"wrote {path}")
    click.echo(
        f"The server accepts the workers whose public keys are in {folder / 'authorized'}. "
        "Restart the server and workers to use the keys."
    )
