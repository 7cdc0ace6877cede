"""Statistics for the study: descriptives, questionnaire scores, Friedman tests with
Bonferroni correction and Kendall's W, permutation p-values, post-hoc Wilcoxon tests, and
renderings (text, JSON via ``Analysis.to_dict``, LaTeX Table I).

The Friedman test is implemented from its formula (:mod:`.friedman_test`) and the Wilcoxon
signed-rank test from R's ``wilcox.test`` source (:mod:`.wilcoxon`); SciPy provides the
chi-squared and normal tails, and the tests check both against independent references.
"""

from chameleons.experiment.questionnaires import score_questionnaire
from chameleons.experiment.stats.analysis import (
    DEFAULT_MEASURES,
    PAPER_CONDITION_ORDER,
    Analysis,
    AnalysisError,
    MeasureAnalysis,
    Scale,
    analyze,
    order_conditions,
)
from chameleons.experiment.stats.descriptive import (
    Descriptive,
    PairwiseTest,
    bonferroni,
    describe,
    wilcoxon_pair,
)
from chameleons.experiment.stats.errors import error_score_table
from chameleons.experiment.stats.friedman_test import (
    FriedmanResult,
    PermutationResult,
    average_ranks,
    friedman,
    permutation_p,
)
from chameleons.experiment.stats.render import render_latex, render_text
from chameleons.experiment.stats.rounding import fmt, fmt_p
from chameleons.experiment.stats.scores import DEFAULT_VIEW, VIEW_TITLES, VIEWS, View
from chameleons.experiment.stats.wilcoxon import (
    DEFAULT_RULE,
    WILCOXON_RULES,
    SignedRankResult,
    WilcoxonRule,
    signed_rank_test,
)

__all__ = [
    "DEFAULT_MEASURES",
    "DEFAULT_RULE",
    "DEFAULT_VIEW",
    "PAPER_CONDITION_ORDER",
    "VIEWS",
    "VIEW_TITLES",
    "WILCOXON_RULES",
    "Analysis",
    "AnalysisError",
    "Descriptive",
    "FriedmanResult",
    "MeasureAnalysis",
    "PairwiseTest",
    "PermutationResult",
    "Scale",
    "SignedRankResult",
    "View",
    "WilcoxonRule",
    "analyze",
    "average_ranks",
    "bonferroni",
    "describe",
    "error_score_table",
    "fmt",
    "fmt_p",
    "friedman",
    "order_conditions",
    "permutation_p",
    "render_latex",
    "render_text",
    "score_questionnaire",
    "signed_rank_test",
    "wilcoxon_pair",
]
