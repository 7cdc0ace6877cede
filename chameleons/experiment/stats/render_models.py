"""Effect sizes and models as readable text and as LaTeX tables (beside Table I)."""

from __future__ import annotations

import math
from collections.abc import Mapping

from chameleons.experiment.stats.analysis import Analysis
from chameleons.experiment.stats.effect_sizes import Interval
from chameleons.experiment.stats.friedman_test import PermutationResult
from chameleons.experiment.stats.models import Coefficient, ModelResult, TermTest
from chameleons.experiment.stats.rounding import fmt, fmt_p, p_is
from chameleons.experiment.stats.suggestion_mix import SuggestionMix

UNDEFINED = "undefined"


def number_text(value: float | None, digits: int = 2, missing: str = UNDEFINED) -> str:
    """The software's one rounding rule; ``missing`` for None, NaN or an infinity."""
    if value is None or not math.isfinite(value):
        return missing
    return fmt(value, digits)


def p_text(value: float | None) -> str:
    if value is None or not math.isfinite(value):
        return UNDEFINED
    return fmt_p(value)


_num = number_text
_p = p_text


def interval_text(interval: Interval, digits: int = 2) -> str:
    if interval.estimate is None:
        return interval.note or UNDEFINED
    if interval.ci_low is None or interval.ci_high is None:
        return f"{_num(interval.estimate, digits)} (no interval: {interval.note})"
    text = (
        f"{_num(interval.estimate, digits)} [{_num(interval.ci_low, digits)}, "
        f"{_num(interval.ci_high, digits)}]"
    )
    return text + (" (zero-width interval: not a measure of precision)" if interval.degenerate
                   else "")  # fmt: skip


def effect_sizes_text(analysis: Analysis, labels: Mapping[str, str]) -> list[str]:
    first = next((r.effect_sizes for r in analysis.measures.values() if r.effect_sizes), None)
    if first is None:
        return []
    lines = [
        "",
        f"Effect sizes ({first.confidence:.0%} bootstrap intervals over participants, "
        f"{first.resamples} resamples, seed {first.seed}):",
    ]
    for measure, result in analysis.measures.items():
        effects = result.effect_sizes
        if effects is None:
            continue
        lines.append(f"  {measure:<12} Kendall's W = {interval_text(effects.kendall_w, 3)}")
        for pair in effects.pairs:
            a, b = labels.get(pair.a, pair.a), labels.get(pair.b, pair.b)
            lines.append(
                f"  {'':<12} {a} - {b}: rank-biserial r = {interval_text(pair.rank_biserial)}, "
                f"median difference = {interval_text(pair.median_difference)}"
            )
    return lines


def models_text(analysis: Analysis, labels: Mapping[str, str]) -> list[str]:
    models = analysis.models
    if models is None:
        return []
    lines = ["", "Models (secondary analyses; 95% Wald intervals):"]
    for model in models.fitted:
        lines += ["", f"  {model_title(model)}: {model.formula}", f"    {model.method}"]
        if model.error:
            lines.append(f"    not available: {model.error}")
            continue
        lines.append(
            f"    {model.n_observations} observations from {model.n_participants} participants"
        )
        lines += [f"    test of {test.term}: {test_text(test)}" for test in model.tests]
        for c in model.coefficients:
            lines.append(f"    {_coefficient_name(c, labels):<28} {_coefficient_text(c)}")
        lines += [f"    note: {n}" for n in model.notes]
    lines += [f"  note: {n}" for n in models.notes]
    return lines


def suggestion_mix_text(analysis: Analysis, labels: Mapping[str, str]) -> list[str]:
    mix = analysis.suggestion_mix
    if mix is None:
        return []
    lines = [
        "",
        "Suggestion mix per condition (the kind depends on earlier decisions, so the "
        "acceptance model leaves it out; read differences here as a consequence):",
    ]
    for c in mix.conditions:
        share = "" if c.random_share is None else f" ({_num(100 * c.random_share, 0)}%)"
        lines.append(
            f"  {labels.get(c.condition, c.condition):<22} {c.total} suggestions: "
            f"{c.optimal} optimal, {c.random} random{share}, {c.down} moved down"
        )
    lines.append(f"  random suggestions per participant and condition: {mix_test_text(mix)}")
    lines += [f"  note: {n}" for n in mix.notes]
    return lines


def mix_test_text(mix: SuggestionMix) -> str:
    test = mix.friedman
    if test.chi2 is None:
        return f"Friedman test undefined (n = {test.n}; every participant's counts tied)"
    text = f"Friedman chi2({test.df}) = {_num(test.chi2)}, p {p_is(test.p)}"
    if mix.permutation is not None:
        text += f", {permutation_label(mix.permutation)} p {p_is(mix.permutation.p)}"
    return text + f", n = {test.n}"


def permutation_label(permutation: PermutationResult) -> str:
    if permutation.method == "exact":
        return "exact permutation"
    return f"Monte Carlo permutation ({permutation.resamples} resamples, seed {permutation.seed})"


def test_text(test: TermTest) -> str:
    wald = f"Wald chi2({test.df}) = {_num(test.chi2)}, p = {_p(test.p)}"
    if test.f is None or test.p_f is None:
        return wald
    return f"F({test.df}, {test.df_denominator}) = {_num(test.f)}, p = {_p(test.p_f)} ({wald})"


def _coefficient_name(c: Coefficient, labels: Mapping[str, str]) -> str:
    if c.term == "Intercept":
        return "intercept"
    level = labels.get(c.level, c.level) if c.term == "condition" else c.level
    return f"{c.term} = {level}"


def _coefficient_text(c: Coefficient) -> str:
    text = (
        f"{_num(c.estimate, 3)} [{_num(c.ci_low, 3)}, {_num(c.ci_high, 3)}], "
        f"z = {_num(c.z)}, p = {_p(c.p)}"
    )
    if c.odds_ratio is not None:
        text += f"; odds ratio {_num(c.odds_ratio)} [{_num(c.or_ci_low)}, {_num(c.or_ci_high)}]"
    return text


def effect_sizes_latex(analysis: Analysis, labels: Mapping[str, str]) -> list[str]:
    rows = []
    for measure, result in analysis.measures.items():
        effects = result.effect_sizes
        if effects is None:
            continue
        w = _tex_interval(effects.kendall_w, 3)
        rows.append(rf"    {tex(measure)} & Kendall's $W$ & {w} \\")
        for pair in effects.pairs:
            name = f"{labels.get(pair.a, pair.a)} -- {labels.get(pair.b, pair.b)}"
            rows.append(rf"    & {tex(name)}: $r_{{rb}}$ & {_tex_interval(pair.rank_biserial)} \\")
            rows.append(
                rf"    & {tex(name)}: median diff. & {_tex_interval(pair.median_difference)} \\"
            )
        rows.append(r"    \hline")
    if not rows:
        return []
    return [
        r"\begin{table}[]",
        r"    \centering",
        r"    \caption{Effect sizes with 95\% bootstrap confidence intervals (resampling "
        r"participants). $^\dagger$: zero-width interval (at least 95\% of the resamples gave "
        r"the same value), not a measure of precision.}",
        r"    \begin{tabular}{ |l|l|c| }",
        r"    \hline",
        r"    Measure & Effect & Estimate [95\% CI] \\",
        r"    \hline",
        *rows,
        r"    \end{tabular}",
        r"    \label{tab:effects}",
        r"\end{table}",
    ]


def models_latex(analysis: Analysis, labels: Mapping[str, str]) -> list[str]:
    models = analysis.models
    if models is None:
        return []
    rows = []
    for model in (m for m in models.fitted if not m.error):
        condition = model.test("condition")
        test = ""
        if condition and condition.f is not None and condition.p_f is not None:
            test = (
                rf" ($F({condition.df}, {condition.df_denominator})={_num(condition.f)}$, "
                rf"$p={_p(condition.p_f)}$)"
            )
        elif condition:
            test = rf" ($\chi^2({condition.df})={_num(condition.chi2)}$, $p={_p(condition.p)}$)"
        rows.append(rf"    \multicolumn{{3}}{{|l|}}{{{tex(model_title(model))}{test}}} \\")
        for c in model.coefficients:
            if c.term == "Intercept":
                continue
            rows.append(rf"    & {tex(_coefficient_name(c, labels))} & {_tex_coefficient(c)} \\")
        rows.append(r"    \hline")
    if not rows:
        return []
    return [
        r"\begin{table}[]",
        r"    \centering",
        r"    \caption{Models: odds ratios (acceptance, GEE) and score differences "
        r"(linear mixed models) with 95\% Wald confidence intervals.}",
        r"    \begin{tabular}{ |l|l|c| }",
        r"    \hline",
        r"    Model & Effect & Estimate [95\% CI] \\",
        r"    \hline",
        *rows,
        r"    \end{tabular}",
        r"    \label{tab:models}",
        r"\end{table}",
    ]


def _tex_interval(interval: Interval, digits: int = 2) -> str:
    if interval.estimate is None:
        return "--"
    if interval.ci_low is None or interval.ci_high is None:
        return f"${_num(interval.estimate, digits)}$"
    text = (
        f"${_num(interval.estimate, digits)}$ [${_num(interval.ci_low, digits)}$, "
        f"${_num(interval.ci_high, digits)}$]"
    )
    return text + ("$^\\dagger$" if interval.degenerate else "")


def _tex_coefficient(c: Coefficient) -> str:
    if c.odds_ratio is not None:
        return f"${_num(c.odds_ratio)}$ [${_num(c.or_ci_low)}$, ${_num(c.or_ci_high)}$]"
    return f"${_num(c.estimate)}$ [${_num(c.ci_low)}$, ${_num(c.ci_high)}$]"


def model_title(model: ModelResult) -> str:
    """The model's name as reports print it; the kind-adjusted acceptance model says it is
    the secondary one."""
    if model.name == "acceptance_by_kind":
        return "acceptance adjusted for suggestion kind (secondary: kind is a mediator)"
    if model.name == "acceptance":
        return "acceptance (total effect of condition)"
    return model.name


def model_by_name(analysis: Analysis, name: str) -> ModelResult | None:
    models = analysis.models
    if models is None:
        return None
    return next((m for m in models.fitted if m.name == name), None)


def tex(text: str) -> str:
    for char, escaped in [
        ("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("$", r"\$"),
        ("#", r"\#"), ("_", r"\_"), ("{", r"\{"), ("}", r"\}"),
    ]:  # fmt: skip
        text = text.replace(char, escaped)
    return text
