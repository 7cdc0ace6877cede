"""An analysis as readable text, or as LaTeX in the layout of the paper's Table I."""

from __future__ import annotations

from collections.abc import Mapping
from typing import Literal

from chameleons.experiment.stats.analysis import Analysis, MeasureAnalysis
from chameleons.experiment.stats.descriptive import Descriptive, PairwiseTest
from chameleons.experiment.stats.reliability import Reliability
from chameleons.experiment.stats.render_models import (
    effect_sizes_latex,
    effect_sizes_text,
    models_latex,
    models_text,
    suggestion_mix_text,
)
from chameleons.experiment.stats.rounding import RULE, fmt, p_is

MEASURE_LABELS = {
    "accepted": "Accepted robot suggestions",
    "credibility": "Credibility",
    "likeability": "Likeability",
    "trust": "Trust",
}
MEASURE_RANGES = {"accepted": "0-3", "credibility": "1-7", "likeability": "1-7", "trust": "1-7"}
CONDITION_LABELS = {"natural": "Natural movement", "copy": "Copy", "still": "Still"}
UNDEFINED = "undefined"


def render_text(
    analysis: Analysis,
    condition_labels: Mapping[str, str] | None = None,
    *,
    measure_labels: Mapping[str, str] | None = None,
    measure_ranges: Mapping[str, str] | None = None,
) -> str:
    labels = {**CONDITION_LABELS, **(condition_labels or {})}
    names = {**MEASURE_LABELS, **(measure_labels or {})}
    ranges = {**MEASURE_RANGES, **(measure_ranges or {})}
    conditions = analysis.conditions
    header = f"{'measure (median, mean ± SD)':<34}" + "".join(
        f"{labels.get(c, c):<22}" for c in conditions
    )
    lines = [f"Analysed {analysis.view_title}.", analysis.summary(), "", header, "-" * len(header)]
    for measure, result in analysis.measures.items():
        name = f"{names.get(measure, measure)} ({ranges.get(measure, '')})"
        cells = "".join(f"{result.conditions[c].cell():<22}" for c in conditions)
        lines.append(f"{name.replace(' ()', ''):<34}{cells}")
    lines += ["", "Friedman tests (permutation p, exact where feasible; Kendall's W):"]
    lines += [f"  {m:<12} {_friedman_text(r)}" for m, r in analysis.measures.items()]
    lines += ["", "Post-hoc pairwise tests:"]
    for measure, result in analysis.measures.items():
        if not result.posthoc:
            lines.append(f"  {measure:<12} {result.posthoc_note}")
        for test in result.posthoc:
            lines.append(f"  {measure:<12} {posthoc_text(test)}")
    lines += effect_sizes_text(analysis, labels) + suggestion_mix_text(analysis, labels)
    lines += models_text(analysis, labels)
    lines += reliability_text(analysis, names, labels)
    notes = [n for r in analysis.measures.values() for n in r.notes] + analysis.notes
    notes.append(f"Numbers are {RULE}.")
    lines += ["", "Notes:", *(f"  - {n}" for n in notes)]
    return "\n".join(lines)


def render_latex(
    analysis: Analysis,
    condition_labels: Mapping[str, str] | None = None,
    *,
    layout: Literal["paper", "wide"] = "paper",
    measure_labels: Mapping[str, str] | None = None,
    measure_ranges: Mapping[str, str] | None = None,
) -> str:
    """``paper``: Table I's layout (a multirow block per measure, a row per condition with
    median and mean $\\pm$ SD; needs ``\\usepackage{multirow}``). ``wide``: a row per
    measure, a column per condition, cells "median, mean $\\pm$ SD"."""
    labels = {**CONDITION_LABELS, **(condition_labels or {})}
    names = {**MEASURE_LABELS, **(measure_labels or {})}
    ranges = {**MEASURE_RANGES, **(measure_ranges or {})}
    if layout == "paper":
        body = _paper_body(analysis, labels, names)
    else:
        body = _wide_body(analysis, labels, names)
    comments = [f"% Analysed {analysis.view_title}. {analysis.summary()}"]
    comments += [f"% Friedman {m}: {_friedman_text(r)}" for m, r in analysis.measures.items()]
    scales = sorted({ranges[m] for m in analysis.measures if m != "accepted" and m in ranges})
    return "\n".join(
        [
            *comments,
            r"\begin{table}[]",
            r"    \centering",
            r"    \caption{Median and mean $\pm$ SD per condition of the accepted robot "
            rf"suggestions ({ranges.get('accepted', '')}) and the questionnaire scores "
            rf"({', '.join(scales)}).}}",
            *body,
            r"    \label{tab:stats}",
            r"\end{table}",
            *effect_sizes_latex(analysis, labels),
            *models_latex(analysis, labels),
        ]
    )


def _paper_body(
    analysis: Analysis, labels: Mapping[str, str], names: Mapping[str, str]
) -> list[str]:
    k = len(analysis.conditions)
    lines = [
        r"    \begin{tabular}{ |c|c|c|c| }",
        r"    \hline",
        r"    Measure & Condition & Median & Average \\",
        r"    \hline",
    ]
    for measure, result in analysis.measures.items():
        lines.append(rf"    \multirow{{{k}}}*{{{_tex(names.get(measure, measure))}}}")
        for condition in analysis.conditions:
            d = result.conditions[condition]
            median = fmt(d.exact_median, 1, "--")
            lines.append(
                rf"    & {_tex(labels.get(condition, condition))} & {median} & "
                rf"{_mean_sd_tex(d)} \\"
            )
        lines.append(r"    \hline")
    lines.append(r"    \end{tabular}")
    return lines


def _wide_body(
    analysis: Analysis, labels: Mapping[str, str], names: Mapping[str, str]
) -> list[str]:
    columns = "|l|" + "c|" * len(analysis.conditions)
    heads = " & ".join(_tex(labels.get(c, c)) for c in analysis.conditions)
    lines = [rf"    \begin{{tabular}}{{{columns}}}", r"    \hline", rf"    Measure & {heads} \\"]
    lines.append(r"    \hline")
    for measure, result in analysis.measures.items():
        cells = " & ".join(
            f"{fmt(d.exact_median, 1, '--')}, {_mean_sd_tex(d)}"
            for d in (result.conditions[c] for c in analysis.conditions)
        )
        lines.append(rf"    {_tex(names.get(measure, measure))} & {cells} \\")
    lines += [r"    \hline", r"    \end{tabular}"]
    return lines


def posthoc_text(test: PairwiseTest) -> str:
    """One post-hoc test in words (the text report and the analysis page)."""
    if test.p is None:
        return f"{test.a} vs {test.b}: undefined ({test.note}), n = {test.n}"
    return (
        f"{test.a} vs {test.b}: V = {fmt(test.v, 1)}, W = {fmt(test.statistic, 1)}, "
        f"p {p_is(test.p)}, Bonferroni p {p_is(test.p_bonferroni)}, n = {test.n}"
        f" ({test.method}{'; ' + test.note if test.note else ''})"
    )


def _friedman_text(result: MeasureAnalysis) -> str:
    """The permutation p first (exact at the paper's n), then the asymptotic one."""
    test = result.friedman
    if test.chi2 is None:
        return f"chi2 {UNDEFINED} (n = {test.n}; every participant's values tied or no data)"
    text = f"chi2({test.df}) = {fmt(test.chi2, 2)}, Kendall's W = {fmt(test.kendall_w, 3)}, "
    text += f"n = {test.n}; "
    p, p_bonferroni, how = result.primary_p
    perm = result.permutation
    if perm is not None and perm.method != "exact":
        how += f" ({perm.resamples} resamples, seed {perm.seed})"
    if perm is None or perm.p is None:
        return text + f"p {p_is(test.p)}, Bonferroni p {p_is(result.p_bonferroni)}"
    return text + (
        f"{how} p {p_is(p)}, Bonferroni p {p_is(p_bonferroni)} (asymptotic chi-squared "
        f"p {p_is(test.p)}, Bonferroni p {p_is(result.p_bonferroni)})"
    )


def _mean_sd_tex(d: Descriptive) -> str:
    if d.exact_mean is None:
        return "--"
    return rf"${fmt(d.exact_mean, 1)}\pm{fmt(d.exact_sd, 1, '--')}$"


def _tex(text: str) -> str:
    for char, escaped in [
        ("\\", r"\textbackslash{}"), ("&", r"\&"), ("%", r"\%"), ("$", r"\$"),
        ("#", r"\#"), ("_", r"\_"), ("{", r"\{"), ("}", r"\}"),
    ]:  # fmt: skip
        text = text.replace(char, escaped)
    return text


def reliability_line(result: Reliability, title: str) -> str:
    """``title: alpha = 0.81, 95% CI [0.70, 0.89] (percentile bootstrap over participants;
    n = 36 complete ratings from 12 participants, 12 items)``."""
    who = f" from {result.participants} participants" if result.participants else ""
    counts = f"n = {result.n} complete ratings{who}, {result.items} items"
    if result.alpha is None:
        return f"{title}: alpha {UNDEFINED} ({result.note}; {counts})"
    level = round(result.confidence * 100)
    if result.ci_low is None or result.ci_high is None:
        interval = f"no interval ({result.note})"
    else:
        interval = f"{level}% CI [{fmt(result.ci_low, 2)}, {fmt(result.ci_high, 2)}]"
    return f"{title}: alpha = {fmt(result.alpha, 2)}, {interval} ({result.method}; {counts})"


def reliability_text(
    analysis: Analysis, names: Mapping[str, str], labels: Mapping[str, str]
) -> list[str]:
    if not analysis.reliability:
        return []
    lines = [
        "",
        "Internal consistency (Cronbach's alpha): all ratings, with an interval that resamples",
        "participants (their ratings are not independent); and per condition (one rating per",
        "participant), with Feldt's interval:",
    ]
    for result in analysis.reliability:
        lines.append("  " + reliability_line(result, names.get(result.scale, result.scale)))
        lines += [
            "    " + reliability_line(c, labels.get(c.condition, c.condition))
            for c in result.by_condition
        ]
    return lines
