"""``chameleons power``: how many participants the planned study needs, by simulation."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import click

from chameleons.cli.plan_command import load_study_option


def _pairs(values: tuple[str, ...], option: str) -> dict[str, float]:
    """``("copy=0.6", ...)`` -> ``{"copy": 0.6}``."""
    result = {}
    for value in values:
        name, _, number = value.partition("=")
        try:
            result[name.strip()] = float(number)
        except ValueError:
            raise click.BadParameter(
                f"{value!r}: use CONDITION=NUMBER", param_hint=option
            ) from None
    return result


def _sizes(text: str | None) -> tuple[int, ...] | None:
    if not text:
        return None
    try:
        sizes = tuple(sorted({int(part) for part in text.split(",") if part.strip()}))
    except ValueError:
        raise click.BadParameter(f"{text!r}: use e.g. 12,24,36", param_hint="--n") from None
    if not sizes or sizes[0] < 2 or sizes[-1] > 1000:
        raise click.BadParameter("sample sizes must be between 2 and 1000", param_hint="--n")
    return sizes


@click.command("power")
@click.option("--study", "study_file", type=click.Path(dir_okay=False, path_type=Path),
              help="Study YAML (default: the paper's study).")  # fmt: skip
@click.option("--accept", multiple=True, metavar="COND=P",
              help="P(accept a suggestion) per condition for a typical participant "
              "(default for the paper's conditions: its pilot, Table I).")  # fmt: skip
@click.option("--accept-sd", type=click.FloatRange(min=0), default=1.0, show_default=True,
              help="SD of participants' acceptance tendencies (logit scale).")  # fmt: skip
@click.option(
    "--score",
    multiple=True,
    metavar="COND=MEAN",
    help="Mean questionnaire score per condition (default: the paper's credibility).",
)
@click.option("--score-sd-between", type=click.FloatRange(min=0), default=0.7, show_default=True)
@click.option("--score-sd-within", type=click.FloatRange(min=0, min_open=True), default=0.7,
              show_default=True)  # fmt: skip
@click.option("--n", "sizes", help="Sample sizes, e.g. 12,24,36 (default: 1-5 balance periods).")
@click.option("--replicates", type=click.IntRange(1, 200_000), default=2000, show_default=True,
              help="Simulated studies per N (Friedman tests, score model).")  # fmt: skip
@click.option(
    "--model-replicates",
    type=click.IntRange(0, 20_000),
    default=200,
    show_default=True,
    help="Simulated studies per N for the acceptance model (GEE).",
)
@click.option("--alpha", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=0.05,
              show_default=True)  # fmt: skip
@click.option(
    "--tests",
    type=click.IntRange(min=1),
    default=None,
    help="Bonferroni divisor (default: the study's measures, 4 for the paper).",
)
@click.option("--target", type=click.FloatRange(0, 1, min_open=True, max_open=True), default=0.8,
              show_default=True)  # fmt: skip
@click.option("--reference", default=None, help="Condition the models compare with.")
@click.option("--seed", type=int, default=0, show_default=True, help="Simulation seed.")
@click.option("--plan-seed", type=int, default=0, show_default=True,
              help="Counterbalancing plan seed (the design simulated).")  # fmt: skip
@click.option("--format", "output_format", type=click.Choice(["text", "json"]), default="text",
              show_default=True)  # fmt: skip
def power_command(study_file: Path | None, accept: tuple[str, ...], accept_sd: float,
                  score: tuple[str, ...], score_sd_between: float, score_sd_within: float,
                  sizes: str | None, replicates: int, model_replicates: int, alpha: float,
                  tests: int | None, target: float, reference: str | None, seed: int,
                  plan_seed: int, output_format: str) -> None:  # fmt: skip
    """Power of the Friedman tests and the models at N = 12, 24, ... and the N needed,
    by simulating the planned design under assumed effects."""
    from chameleons.experiment.stats.power import PowerError
    from chameleons.experiment.stats.power_render import power_markdown
    from chameleons.experiment.stats.power_service import PowerRequest, run_power

    study = load_study_option(study_file)
    request = PowerRequest.for_study(
        study,
        acceptance=_pairs(accept, "--accept"),
        scores=_pairs(score, "--score"),
        acceptance_sd=accept_sd,
        score_sd_between=score_sd_between,
        score_sd_within=score_sd_within,
        sample_sizes=_sizes(sizes),
        replicates=replicates,
        model_replicates=model_replicates,
        alpha=alpha,
        tests=tests,
        target=target,
        reference=reference,
        seed=seed,
        plan_seed=plan_seed,
    )

    def progress(done: int, total: int) -> None:
        click.echo(f"\rsimulating: {done}/{total} data sets", nl=False, err=True)

    try:
        result = run_power(study, request, progress)
    except PowerError as exc:
        raise click.ClickException(str(exc)) from exc
    click.echo("", err=True)
    if output_format == "json":
        data: dict[str, Any] = result.to_dict()
        click.echo(json.dumps(data, indent=2))
    else:
        labels = {c.id: c.label for c in study.conditions}
        click.echo(power_markdown(result.to_dict(), labels))
