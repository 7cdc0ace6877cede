"""The CLI imports a command's module only when that command runs (issue: a CLI that
answers at once): ``chameleons --help`` lists every command without importing any."""

from __future__ import annotations

import json
import subprocess
import sys

import click
from click.testing import CliRunner

from chameleons.cli.main import COMMANDS, cli

# What ``--help`` must not import: the heavy libraries and every command's own module.
NOT_FOR_HELP = ("fastapi", "scipy", "sqlalchemy", "pandas", "argon2", "statsmodels", "zmq",
                "chameleons.backend", "chameleons.worker", "chameleons.experiment",
                *(f"chameleons.cli.{module}" for module, _, _ in COMMANDS.values()))  # fmt: skip


def test_the_listing_says_what_each_command_says_of_itself() -> None:
    ctx = click.Context(cli)
    assert cli.list_commands(ctx) == sorted(COMMANDS)
    for name, (_, _, listed) in COMMANDS.items():
        command = cli.get_command(ctx, name)
        assert command is not None
        assert command.name == name
        assert command.get_short_help_str(limit=1000) == listed, name


def test_help_lists_every_command_and_imports_none_of_them() -> None:
    probe = (
        "import sys, json\n"
        "from chameleons.cli.main import cli\n"
        "try:\n"
        "    cli(['--help'], prog_name='chameleons')\n"
        "except SystemExit:\n"
        "    pass\n"
        f"print(json.dumps(sorted(m for m in sys.modules if m.startswith({NOT_FOR_HELP!r}))))\n"
    )
    done = subprocess.run([sys.executable, "-c", probe], capture_output=True, text=True,
                          check=True, timeout=120)  # fmt: skip
    help_text, _, imported = done.stdout.rstrip().rpartition("\n")
    for name in COMMANDS:
        assert f"\n  {name} " in help_text
    assert json.loads(imported) == []


def test_a_command_still_runs_and_an_unknown_one_is_refused() -> None:
    runner = CliRunner()
    result = runner.invoke(cli, ["plan", "--participants", "3", "--format", "csv"])
    assert result.exit_code == 0, result.output
    rows = result.stdout.splitlines()  # the balance summary goes to stderr
    assert rows[0].startswith("participant,position,condition")
    assert len(rows) == 1 + 3 * 3  # three participants, three interactions each
    result = runner.invoke(cli, ["plna"])
    assert result.exit_code == 2
    assert "No such command 'plna'" in result.output
