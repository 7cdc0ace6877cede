"""``chameleons study``: start a lab's own study from a shipped template.

The templates are the study files under ``chameleons/experiment/studies/`` (one folder each,
``study.yaml``); docs/design-space.md gives each one's rationale and citations.
"""

from __future__ import annotations

from pathlib import Path

import click

from chameleons.experiment.study import StudyError, load_study
from chameleons.experiment.templates import study_templates as templates


@click.group()
def study() -> None:
    """Start a lab's own study from a shipped template (chameleons study templates)."""


@study.command("templates")
def list_templates() -> None:
    """List the shipped study templates with their names and conditions."""
    for name, path in templates().items():
        spec = load_study(path)
        click.echo(f"{name:<14} {spec.name}: {', '.join(spec.condition_ids)}")


@study.command("new")
@click.option("--template", "template", required=True, metavar="NAME",
              help="A shipped template (chameleons study templates lists them).")  # fmt: skip
@click.argument("directory", type=click.Path(file_okay=False, path_type=Path))
def new(template: str, directory: Path) -> None:
    """Copy the template's study.yaml into DIRECTORY (created) to edit and load."""
    found = templates()
    if template not in found:
        raise click.BadParameter(
            f"no template {template!r}; the templates are {', '.join(found)}",
            param_hint="--template",
        )
    target = directory / "study.yaml"
    if target.exists():
        raise click.ClickException(f"{target} exists already; choose another directory.")
    text = found[template].read_text(encoding="utf-8")
    try:
        load_study(found[template])
    except StudyError as exc:  # a template that does not load is a bug, said plainly
        raise click.ClickException(f"the template {template} does not load: {exc}") from exc
    directory.mkdir(parents=True, exist_ok=True)
    target.write_text(text, encoding="utf-8")
    click.echo(f"Wrote {target} (from the {template} template).")
    click.echo(f"Check its plan: chameleons plan --study {target} -n 12")
    click.echo("Then load it on the Studies page (paste the file into Study YAML).")


@study.command("power")
@click.argument("template", required=False)
def power(template: str | None) -> None:
    """Sample-size presets of the design-space templates (all, or TEMPLATE): participants
    needed for conventional effect sizes and the smallest effect detected at N = 12..48
    (statsmodels; the assumptions are in docs/design-space.md)."""
    from chameleons.experiment import power_presets as presets

    chosen: tuple[presets.TemplatePower, ...] = presets.TEMPLATES
    if template is not None:
        found = presets.by_name(template)
        if found is None:
            names = ", ".join(t.template for t in presets.TEMPLATES)
            raise click.BadParameter(f"no preset for {template!r}; the templates with "
                                     f"presets are {names}", param_hint="TEMPLATE")  # fmt: skip
        chosen = (found,)
    for item in chosen:
        click.echo(presets.render(item))
    click.echo(presets.render_references(), nl=False)
