"""Statistics for the study: descriptives, questionnaire scores, Friedman tests with
Bonferroni correction and Kendall's W, permutation p-values, post-hoc Wilcoxon tests, and
renderings (text, JSON via ``Analysis.to_dict``, LaTeX Table I).

The Friedman test is implemented from its formula (:mod:`.friedman`); SciPy serves as the
independent reference in the tests and provides the chi-squared tail and the Wilcoxon test.
"""

from chameleons.experiment.questionnaires import score_questionnaire
from chameleons.experiment.stats.analysis import (
    DEFAULT_MEASURES,
    PAPER_CONDITION_ORDER,
    Analysis,
    AnalysisError,
    MeasureAnalysis,
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
from chameleons.experiment.stats.render import (
    condition_labels,
    condition_order,
    measure_labels,
    measure_ranges,
    render_latex,
    render_text,
)

__all__ = [
    "DEFAULT_MEASURES",
    "PAPER_CONDITION_ORDER",
    "Analysis",
    "AnalysisError",
    "Descriptive",
    "FriedmanResult",
    "MeasureAnalysis",
    "PairwiseTest",
    "PermutationResult",
    "analyze",
    "average_ranks",
    "bonferroni",
    "condition_labels",
    "condition_order",
    "describe",
    "error_score_table",
    "friedman",
    "measure_labels",
    "measure_ranges",
    "order_conditions",
    "permutation_p",
    "render_latex",
    "render_text",
    "score_questionnaire",
    "wilcoxon_pair",
]
