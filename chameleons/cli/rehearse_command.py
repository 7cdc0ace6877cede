"""`chameleons rehearse`: run N whole sessions with a scripted wizard and participant."""

from __future__ import annotations

import click

from chameleons.cli.common import load_settings
from chameleons.launch.interrupts import Interrupts, interrupts
from chameleons.rehearsal import runner
from chameleons.rehearsal.patterns import PATTERNS
from chameleons.rehearsal.runner import Options, RehearsalError, Summary, Target
from chameleons.rehearsal.script import SCRIPTS


@click.command()
@click.option(
    "--participants",
    "-n",
    type=click.IntRange(1, 1000),
    required=True,
    help="How many rehearsal sessions to run, one after the other.",
)
@click.option(
    "--seed",
    type=int,
    default=0,
    show_default=True,
    help="Seed of the participants' answers (same seed, same answers).",
)
@click.option(
    "--pattern",
    type=click.Choice(sorted(PATTERNS)),
    default="neutral",
    show_default=True,
    help="How participants answer; 'effect' builds in an effect of the copy "
    "condition for the analysis to find.",
)
@click.option(
    "--server",
    default=None,
    metavar="URL",
    help="Rehearse against a running server (with --username/--password); "
    "without it an embedded system is started and stopped again.",
)
@click.option("--username", default=None, help="Staff login on --server.")
@click.option(
    "--password",
    default=None,
    help="Its password (or CHAMELEONS_REHEARSE_PASSWORD).",
    envvar="CHAMELEONS_REHEARSE_PASSWORD",
)
@click.option(
    "--study",
    "study_id",
    type=int,
    default=None,
    help="Study id (default: the newest active study).",
)
@click.option(
    "--booth",
    default=None,
    help="Booth of the rehearsal sessions [booth-1]. A booth with a real session open is "
    "refused unless named here.",
)
@click.option(
    "--script",
    type=click.Choice(SCRIPTS),
    default="full",
    show_default=True,
    help="Prompts the wizard plays: all of them, a few, or none.",
)
@click.option(
    "--drop-out",
    "drop_out",
    type=click.FloatRange(0.0, 1.0),
    default=0.0,
    show_default=True,
    metavar="RATE",
    help="Share of sessions that drop out (never started, or ended early during an "
    "interaction with a reason), seeded by --seed.",
)
@click.option(
    "--deviate",
    type=click.FloatRange(0.0, 1.0),
    default=0.0,
    show_default=True,
    metavar="RATE",
    help="Share of sessions where the wizard reruns an earlier interaction's condition "
    "(confirmed as a deviation), seeded by --seed.",
)
@click.option(
    "--language",
    default=None,
    metavar="CODE",
    help="The participants' language (one of the study's, e.g. sv); default: the study's "
    "default. The phone, the study's texts and the console's prompts follow it.",
)
@click.option(
    "--hold",
    type=click.FloatRange(0.0, 3600.0),
    default=0.0,
    show_default=True,
    metavar="SECONDS",
    help="Each interaction's discussion lasts at least this long (the simulated face is "
    "recorded meanwhile), so its synchrony can be measured: it needs the first second "
    "(left out), the window and the lag (37 s by default), e.g. --hold 45.",
)
@click.option(
    "--simulate-face/--no-simulate-face",
    default=True,
    show_default=True,
    help="Embedded system: feed the worker a synthetic face.",
)
def rehearse(
    participants: int, seed: int, pattern: str, server: str | None, username: str | None,
    password: str | None, study_id: int | None, booth: str | None, script: str,
    drop_out: float, deviate: float, language: str | None, hold: float, simulate_face: bool,
) -> None:  # fmt: skip
    """Run whole sessions with a scripted wizard and participant, marked as rehearsals.

    They use the server's HTTP API and WebSockets as people do, with a real worker
    driving the virtual robot. Rehearsals stay out of balance tables, exports and the
    analysis unless asked for (chameleons export --include-rehearsal).
    """
    options = Options(
        participants,
        seed,
        pattern,
        script,
        drop_out=drop_out,
        deviate=deviate,
        language=language,
        hold=hold,
    )
    # Ctrl-C and SIGTERM end it with 130 / 143 once everything it started has stopped, so a
    # script that chains `rehearse` and `export` never exports a half-finished rehearsal.
    with interrupts() as stops:
        try:
            if server is not None:
                if not username or not password:
                    raise click.UsageError("--server needs --username and --password.")
                target = Target(server.rstrip("/"), username, password, study_id,
                                booth or "booth-1", booth_chosen=booth is not None)  # fmt: skip
                _report(rehearse_sessions(target, options, stops))
                return
            from chameleons.rehearsal.embedded import embedded_system

            click.echo("Starting an embedded server, worker (virtual robot) and simulated face...")
            with embedded_system(
                load_settings(), study_id, simulate_face, booth, stops=stops
            ) as target:
                click.echo(f"Server on {target.base_url}; rehearsing {participants} sessions.")
                _report(rehearse_sessions(target, options, stops))
        except RehearsalError as error:
            raise click.ClickException(str(error)) from error


def rehearse_sessions(target: Target, options: Options, stops: Interrupts | None = None) -> Summary:
    def progress(line: str) -> None:
        if stops is not None:
            stops.check()  # a signal whose exception was lost ends the run here
        click.echo(line)

    return runner.rehearse(target, options, progress=progress)


def _report(summary: Summary) -> None:
    click.echo("")
    for line in summary.lines():
        click.echo(line)
