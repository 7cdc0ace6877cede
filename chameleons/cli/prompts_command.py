"""``chameleons prompts import``: Live Link Face takes -> an actor's prompt assets."""

from __future__ import annotations

from pathlib import Path

import click

from chameleons.prompts.importer import (
    AUDIO_FORMATS,
    ImportOptions,
    TakeImportError,
    import_batch,
    import_natural,
    import_take,
)
from chameleons.worker.ingest.livelink import rotation_factor

_EXISTING = click.Path(exists=True, path_type=Path)


@click.group()
def prompts() -> None:
    """Work with the prompt catalogue (prompts/<actor>/)."""


@prompts.command("import")
@click.argument("actor_dir", type=click.Path(file_okay=False, path_type=Path))
@click.argument("take", type=_EXISTING, required=False)
@click.option("--prompt-id", help="Import TAKE as this prompt of the actor's manifest.")
@click.option("--wav", type=_EXISTING, help="The take's audio (default: the WAV beside it).")
@click.option("--batch", type=_EXISTING,
              help="CSV with columns take,prompt_id[,wav]: import every take listed.")  # fmt: skip
@click.option("--natural", "natural_name",
              help="Import TAKE as natural/<NAME>.npz for the 'natural' behaviour.")  # fmt: skip
@click.option("--rotation-scale", default="radians", show_default=True,
              help="Unit of the take's head/eye columns: radians (the Live Link Face app), "
              "degrees/180, degrees or a factor (see docs/livelink.md).")  # fmt: skip
@click.option("--audio-offset", type=float, default=0.0, show_default=True,
              help="Seconds the audio starts after the CSV's first row.")  # fmt: skip
@click.option("--silence-db", type=float, default=-35.0, show_default=True,
              help="Trim audio this many dB below the loudest part at both ends.")  # fmt: skip
@click.option("--pad", type=float, default=0.1, show_default=True,
              help="Seconds of silence kept before and after the speech.")  # fmt: skip
@click.option("--audio-format", type=click.Choice(AUDIO_FORMATS), default="mp3",
              show_default=True)  # fmt: skip
def import_command(
    actor_dir: Path, take: Path | None, prompt_id: str | None, wav: Path | None,
    batch: Path | None, natural_name: str | None, rotation_scale: str, audio_offset: float,
    silence_db: float, pad: float, audio_format: str,
) -> None:  # fmt: skip
    """Turn Live Link Face takes (CSV + WAV, or a take folder) into prompt assets of the
    actor in ACTOR_DIR: trimmed audio, lip-sync curves, a natural-movement recording, and
    the manifest's audio/lipsync cells. A broken take is reported and left out whole.

    \b
    One take:   chameleons prompts import prompts/m1 takes/hello.csv --prompt-id intro_nova
    A batch:    chameleons prompts import prompts/m1 --batch takes/batch.csv
    Natural:    chameleons prompts import prompts/m1 takes/idle/ --natural idle_1
    """
    modes = [m for m in (prompt_id, batch, natural_name) if m is not None]
    if len(modes) != 1:
        raise click.UsageError("give exactly one of --prompt-id, --batch or --natural")
    if batch is None and take is None:
        raise click.UsageError("give the TAKE (a CSV file or a take folder)")
    try:
        options = ImportOptions(rotation_factor(rotation_scale), audio_offset, silence_db, pad,
                                audio_format)  # fmt: skip
    except ValueError as exc:
        raise click.BadParameter(str(exc), param_hint="--rotation-scale") from exc
    if batch is not None:
        _run_batch(batch, actor_dir, options)
        return
    assert take is not None
    try:
        if natural_name is not None:
            natural = import_natural(take, actor_dir, natural_name, options)
            click.echo(f"natural recording: {natural.path}")
            _echo_notes(natural.notes)
            return
        assert prompt_id is not None
        result = import_take(take, actor_dir, prompt_id, options, wav=wav)
    except TakeImportError as problem:
        raise click.ClickException(f"not imported: {problem}") from problem
    click.echo(f"{result.prompt_id}: {result.duration:.2f} s from {result.trimmed_start:.2f} s, "
               f"{result.frame_rate:g} Hz take -> {result.audio}, {result.lipsync}, "
               f"{result.natural}")  # fmt: skip
    _echo_notes(result.notes)


def _echo_notes(notes: tuple[str, ...], where: str = "") -> None:
    """What the take lacks, where the user imports it (not only in a log)."""
    for note in notes:
        click.echo(f"note: {where}{note}")


def _run_batch(batch: Path, actor_dir: Path, options: ImportOptions) -> None:
    try:
        outcomes = import_batch(batch, actor_dir, options)
    except TakeImportError as problem:
        raise click.ClickException(str(problem)) from problem
    failed = [o for o in outcomes if o.problem is not None]
    for outcome in outcomes:
        if outcome.result is not None:
            click.echo(f"ok      {outcome.entry.prompt_id}: {outcome.result.duration:.2f} s")
            _echo_notes(outcome.result.notes, f"{outcome.entry.prompt_id}: ")
        else:
            click.echo(f"FAILED  {outcome.problem}", err=True)
    click.echo(f"{len(outcomes) - len(failed)} imported, {len(failed)} failed")
    if failed:
        raise click.exceptions.Exit(1)
