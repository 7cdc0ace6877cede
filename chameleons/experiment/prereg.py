"""A preregistration document (Markdown) for a study, to upload to OSF before data
collection: the study configuration and its hash, the counterbalancing plan's seed and
size, the planned N with its power computation, hypotheses, variables, and the analysis
plan exactly as the software will run it.

The hypotheses are generated from the design as a starting point: the PI edits them
before uploading (the document says so at the top).
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

from chameleons import __version__
from chameleons.experiment.blocks import balance_period
from chameleons.experiment.model import Condition, Study
from chameleons.experiment.stats.effect_sizes import DEFAULT_RESAMPLES
from chameleons.experiment.stats.power_render import power_markdown
from chameleons.experiment.suggestions import FALLBACK_WORDS
from chameleons.worker.behaviours.copy_params import in_words

MEASURE_WORDS = {
    "accepted": "the number of robot suggestions the participant accepts in an interaction",
}

# How each suggestion rule picks its move, in the words of the study YAML's comments.
SUGGESTION_RULE_WORDS = {
    "expert_place": "each moving one item the participant has not declined from outside its "
    "place in the expert order to its place (preferring a move that lowers the ranking's "
    "error, then a move up, then the most important item)",
    "best_move": "each the single move of one item (up or down) that most lowers the "
    "ranking's error against the expert order",
    "up_only": "each moving the most important item below its expert position up to it",
}


@dataclass(frozen=True)
class PlanFacts:
    """The counterbalancing plan as stored: its seed and how many rows it has."""

    seed: int
    rows: int
    config_hash: str
    created: str  # ISO date of the document


def preregistration(
    study: Study,
    plan: PlanFacts,
    power: dict[str, Any] | None = None,
    *,
    alpha: float = 0.05,
    reference: str | None = None,
) -> str:
    labels = {c.id: c.label for c in study.conditions}
    baseline = reference or ("still" if "still" in study.condition_ids else study.condition_ids[0])
    sections = [
        _header(study, plan),
        _hypotheses(study, labels),
        _design(study, plan, labels),
        _sampling(study, plan, power, labels),
        _variables(study),
        _analysis(study, alpha, labels, baseline),
        _appendix(study),
    ]
    return "\n\n".join(sections) + "\n"


def _header(study: Study, plan: PlanFacts) -> str:
    return "\n".join(
        [
            f"# Preregistration: {study.name}",
            "",
            f"Generated {plan.created} by Mechanical Chameleons {__version__} from study "
            f"configuration `{plan.config_hash}` (SHA-256 of its canonical JSON, in the appendix).",
            "",
            "> Review before uploading: the hypotheses below are generated from the design; "
            "state your own expected directions where you have them.",
            "",
            study.description,
        ]
    )


def _hypotheses(study: Study, labels: dict[str, str]) -> str:
    conditions = ", ".join(labels[c] for c in study.condition_ids)
    lines = ["## Hypotheses", ""]
    for number, measure in enumerate(study.measures, start=1):
        lines.append(
            f"- H{number} ({_measure_name(study, measure)}): the conditions ({conditions}) differ "
            f"in {_measure_words(study, measure)}."
        )
    lines += [
        "",
        "Each is tested two-sided; the null hypothesis is that the conditions do not differ.",
    ]
    return "\n".join(lines)


def _design(study: Study, plan: PlanFacts, labels: dict[str, str]) -> str:
    k = len(study.conditions)
    return "\n".join(
        [
            "## Design",
            "",
            f"Within-subjects: each participant has {k} interactions with the robot, one per "
            "condition:",
            "",
            *(
                f"- **{c.label}** (`{c.id}`): {c.description}{_robot_words(c)}"
                for c in study.conditions
            ),
            "",
            f"Per interaction the participant ranks {study.item_sets.set_size} survival-task "
            f"items; the robot then makes {study.suggestions_per_interaction} suggestions, "
            f"{SUGGESTION_RULE_WORDS[study.suggestion_rule]}, each recorded as accepted or "
            "declined and as *optimal* or *random* (a random upward move, made only "
            f"{FALLBACK_WORDS[study.suggestion_rule]}).",
            "",
            "Counterbalancing (the software's planner, verified independently): condition "
            "orders from a Williams design (each condition equally often in each position, "
            "carry-over balanced); each condition paired equally often with each voice actor, "
            "face and scenario; tasks alternate within a session; every item shown first and "
            f"last. All counts are exact at the end of every balance period of "
            f"{balance_period(study)} participants.",
            "",
            f"- Plan seed: {plan.seed}",
            f"- Plan rows generated: {plan.rows}",
            "- A withdrawn participant's row goes to the next participant (the replacement), so "
            "the completed rows stay a prefix of the plan.",
            "- Participants never see condition names; the wizard does (Wizard-of-Oz).",
        ]
    )


def _sampling(
    study: Study, plan: PlanFacts, power: dict[str, Any] | None, labels: dict[str, str]
) -> str:
    lines = [
        "## Sampling plan",
        "",
        f"Planned sample size: **{plan.rows} participants** (the plan's rows). Data "
        "collection stops when every planned row has a completed session.",
        "",
        "### Power",
        "",
    ]
    if power is None:
        lines.append(
            "No power computation attached (run `chameleons power --format json > power.json` "
            "and pass `--power power.json`, or use the PI page *Power*)."
        )
    else:
        lines += [
            "Simulated with the planned design (this plan's condition orders and item sets) "
            "and analysed as below:",
            "",
            power_markdown(power, labels),
        ]
    return "\n".join(lines)


def _variables(study: Study) -> str:
    lines = [
        "## Variables",
        "",
        "- Manipulated: the robot's facial-gesture condition (within participants).",
        "- Measured, per interaction:",
        f"  - accepted suggestions (0-{study.suggestions_per_interaction});",
    ]
    for q in study.questionnaires_for("interaction"):
        if not q.scored:
            continue
        reverse = [item.id for item in q.numeric_items if item.reverse]
        reversal = f", reverse-keyed items ({', '.join(reverse)}) as points + 1 - value"
        lines.append(
            f"  - {q.title} (`{q.id}`, wording version `{q.version}`): the mean of its "
            f"{len(q.numeric_items)} items on a {q.points}-point scale"
            + (reversal if reverse else "")
            + "; missing if any item is unanswered;"
        )
    lines.append("- Recorded for the models: interaction position, item set, suggestion kind.")
    return "\n".join(lines)


def _analysis(study: Study, alpha: float, labels: dict[str, str], reference: str) -> str:
    m = len(study.measures)
    k = len(study.conditions)
    pairs = k * (k - 1) // 2
    return "\n".join(
        [
            "## Analysis plan",
            "",
            "Primary (as the seed paper):",
            "",
            "- Per measure, a Friedman test across the conditions with the tie correction of "
            "R's `friedman.test`; its p-value is the exact permutation p (the null distribution "
            "of the rank sums enumerated; Monte Carlo with 10 000 seeded resamples only where "
            "that is too costly), the asymptotic chi-squared p reported beside it; an undefined "
            "statistic (every participant's values tied) counts as not significant.",
            f"- Bonferroni over the {m} measures: p x {m}, capped at 1; alpha = {alpha:g}.",
            f"- Post-hoc, only where the corrected permutation p < {alpha:g}: Wilcoxon "
            f"signed-rank tests for the {pairs} pairs (p as R's `wilcox.test`), Bonferroni over "
            "the pairs.",
            "- Effect sizes for every measure and pair, whatever the tests say: Kendall's W, the "
            "matched-pairs rank-biserial correlation (from the signed-rank test's V) and the "
            "median of the paired differences, each with a 95% percentile bootstrap interval "
            f"({DEFAULT_RESAMPLES} resamples of participants, seed 0); an interval of zero "
            "width is reported as such, not as precision.",
            "- Cronbach's alpha per questionnaire: over all ratings with a bootstrap interval "
            "that resamples participants, and per condition with Feldt's interval.",
            "",
            "Secondary:",
            "",
            "- Acceptance of each suggestion: logistic GEE with an exchangeable working "
            "correlation within participant, bias-reduced sandwich standard errors; "
            "`accepted ~ condition + position + item set` (the condition's total effect), "
            f"condition compared with {labels.get(reference, reference)}; joint Wald test of "
            "condition. The suggestion kind (optimal or random fallback) depends on the "
            "participant's earlier decisions, a mediator: the model adjusted for it is "
            "reported as a labelled secondary, and the mix of kinds per condition is reported "
            "with a Friedman test on each participant's number of random suggestions.",
            "- Each questionnaire score: linear mixed model with a random intercept per "
            "participant, `score ~ condition + position`, REML; joint test of condition as an F "
            "test with the within-participant residual degrees of freedom.",
            "",
            "Data handling:",
            "",
            "- Rehearsal sessions (staff practice) are excluded.",
            "- A participant without a value for every condition of a measure is left out of "
            "that measure's rank tests (named in the output); the models use every available "
            "observation.",
            "- Undecided suggestions are left out of the acceptance model.",
        ]
    )


def _appendix(study: Study) -> str:
    config = json.dumps(study.config, indent=2, sort_keys=True, ensure_ascii=False)
    return "\n".join(
        [
            "## Appendix: study configuration",
            "",
            f"SHA-256 `{study.content_hash}`.",
            "",
            "```json",
            config,
            "```",
        ]
    )


def _measure_name(study: Study, measure: str) -> str:
    if measure == "accepted":
        return "accepted suggestions"
    return study.questionnaire(measure).title.lower()


def _measure_words(study: Study, measure: str) -> str:
    if measure in MEASURE_WORDS:
        return MEASURE_WORDS[measure]
    q = study.questionnaire(measure)
    return f"the {q.title.lower()} score participants give the robot ({q.points}-point scale)"


def _robot_words(condition: Condition) -> str:
    """What a ``copy`` condition's robot copies, how late, how much and how often, as the
    study file sets it (issue 31; the parameters themselves are in the study's config)."""
    if condition.behaviour != "copy":
        return ""
    words = in_words(condition.params)
    if condition.params.get("mirror") is None:
        words += ", mirrored as the booth's mirror setting says"
    return f" The robot {words}."
