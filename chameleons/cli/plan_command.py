"""``chameleons plan``: print a counterbalancing plan and its balance report."""

from __future__ import annotations

import csv
import io
import json
from pathlib import Path

import click

from chameleons.experiment.balance import balance_summary
from chameleons.experiment.design import Plan, PlanError, plan, plan_to_dict
from chameleons.experiment.model import Study
from chameleons.experiment.stats.rounding import fmt
from chameleons.experiment.study import StudyError, load_default_study, load_study


def load_study_option(path: Path | None) -> Study:
    """The study at ``path`` (default: the built-in study), problems as a clean CLI error;
    the loader's warnings (e.g. wording shared between questionnaires) go to stderr."""
    try:
        study = load_default_study() if path is None else load_study(path)
    except StudyError as exc:
        raise click.ClickException(str(exc)) from exc
    for warning in study.warnings:
        click.echo(f"Warning: {warning}", err=True)
    return study


@click.command("plan")
@click.option(
    "--participants", "-n", type=click.IntRange(min=1), required=True, help="Rows to plan."
)
@click.option("--seed", type=int, default=0, show_default=True, help="Randomisation seed.")
@click.option(
    "--format",
    "output_format",
    type=click.Choice(["table", "json", "csv"]),
    default="table",
    show_default=True,
    help="csv prints the rows only; the balance summary then goes to stderr.",
)
@click.option(
    "--study",
    "study_path",
    type=click.Path(dir_okay=False, path_type=Path),
    default=None,
    help="Study YAML file (default: the built-in Mechanical Chameleons study).",
)
def plan_command(participants: int, seed: int, output_format: str, study_path: Path | None) -> None:
    """Print the counterbalancing plan for N participants and how balanced it is."""
    study = load_study_option(study_path)
    try:
        result = plan(study, participants, seed)
    except PlanError as exc:
        raise click.ClickException(str(exc)) from exc
    if output_format == "json":
        click.echo(json.dumps(plan_to_dict(result), indent=2))
    elif output_format == "csv":
        click.echo(plan_csv(result), nl=False)
        click.echo(balance_text(result), err=True)
    else:
        click.echo(plan_table(result))
        click.echo(balance_text(result))


def plan_csv(result: Plan) -> str:
    """One line per interaction; the item order joined with ``;``."""
    out = io.StringIO()
    writer = csv.writer(out, lineterminator="\n")
    writer.writerow(
        ["participant", "position", "condition", "actor", "face", "robot_name", "task",
         "item_set", "item_order"]
    )  # fmt: skip
    for row in result.rows:
        for i in row.interactions:
            writer.writerow(
                [row.participant, i.position, i.condition, i.actor, i.face, i.robot_name,
                 i.task, i.item_set, ";".join(i.item_order)]
            )  # fmt: skip
    return out.getvalue()


def plan_table(result: Plan) -> str:
    lines = [
        f"Plan for study {result.study_id} (config {result.study_hash[:12]}), seed {result.seed}, "
        f"{len(result.rows)} participants, balance period {result.balance_period}",
        "",
        f"{'row':>4} {'pos':>3}  {'condition':<10} {'actor':<6} {'face':<7} {'robot':<7} "
        f"{'scenario':<15} item order",
    ]
    for row in result.rows:
        for i in row.interactions:
            number = str(row.participant) if i.position == 1 else ""
            lines.append(
                f"{number:>4} {i.position:>3}  {i.condition:<10} {i.actor:<6} {i.face:<7} "
                f"{i.robot_name:<7} {i.scenario:<15} {', '.join(i.item_order)}"
            )
    return "\n".join(lines)


def balance_text(result: Plan) -> str:
    report = result.balance
    lines = ["", "Balance (constraint numbers from study.md; 0 = extra safeguard):"]
    for c in report.constraints:
        verdict = c.verdict() if c.ok else c.verdict().replace(c.status, c.status.upper(), 1)
        lines.append(
            f"  [{c.constraint}] {c.id:<34} ideal {fmt(c.ideal, 2):>7}  "
            f"largest deviation {fmt(c.max_deviation, 2):>5}  {verdict}"
        )
    lines += [f"  note: {note}" for note in result.notes]
    lines.append(balance_summary(report))
    lines += [f"  - {problem}" for problem in report.problems()]
    return "\n".join(lines)
