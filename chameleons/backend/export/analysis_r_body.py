"""The R code of ``analysis.R`` after its settings and reads: its tests
(:mod:`.analysis_r_tests`) and its models (:mod:`.analysis_r_models`), under the names this
module had before they were split."""

from chameleons.backend.export.analysis_r_models import MODELS
from chameleons.backend.export.analysis_r_tests import TESTS

__all__ = ["MODELS", "TESTS"]
