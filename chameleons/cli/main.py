"""The ``chameleons`` command. Each sub-command lives in its own module and is added here."""

from __future__ import annotations

import click

from chameleons import __version__
from chameleons.cli import (
    analyze_command,
    db_commands,
    demo_command,
    export_command,
    plan_command,
    power_command,
    prereg_command,
    prompts_command,
    rehearse_command,
    serve_command,
    simulate_face_command,
    user_commands,
    worker_command,
)


@click.group(context_settings={"help_option_names": ["-h", "--help"]})
@click.version_option(__version__, prog_name="chameleons")
def cli() -> None:
    """Mechanical Chameleons: run Wizard-of-Oz studies of robot facial mimicry."""


cli.add_command(db_commands.db)
cli.add_command(demo_command.demo)
cli.add_command(serve_command.serve)
cli.add_command(simulate_face_command.simulate_face)
cli.add_command(user_commands.user)
cli.add_command(export_command.export)
cli.add_command(plan_command.plan_command)
cli.add_command(power_command.power_command)
cli.add_command(prereg_command.prereg_command)
cli.add_command(worker_command.worker)
cli.add_command(analyze_command.analyze_command)
cli.add_command(prompts_command.prompts)
cli.add_command(rehearse_command.rehearse)


def main() -> None:
    cli()
