"""The synchrony section of the analysis page and of ``chameleons analyze``: the export's
interaction and score rows through :func:`analyze_synchrony`, so the page, the CLI and an
exported ``interactions.csv`` give the same numbers."""

from __future__ import annotations

from typing import Any

from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.columns import interactions_table, scores_table
from chameleons.backend.export.frames import records, table_frame
from chameleons.backend.export.rows import interaction_rows
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.export.selection import resolve_study
from chameleons.experiment.stats.analysis import PAPER_REFERENCE
from chameleons.experiment.stats.measures import study_measures
from chameleons.experiment.stats.synchrony.outcomes import SynchronyAnalysis, analyze_synchrony
from chameleons.experiment.study import study_from_config


def study_synchrony(
    db: DbSession, study_id: int | None, include_rehearsal: bool = False,
    view: str = "as_planned", reference: str | None = None,
) -> SynchronyAnalysis | None:  # fmt: skip
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    interactions = records(
        table_frame(interactions_table(spec), interaction_rows(db, study, spec, include_rehearsal))
    )
    scores = records(
        table_frame(scores_table(spec), score_rows(db, study, spec, include_rehearsal))
    )
    design = study_measures(spec)
    return analyze_synchrony(
        interactions, scores, conditions=design.order, measures=design.measures,
        reference=reference or PAPER_REFERENCE, view=view,
    )  # fmt: skip


def rows_for_analyze(db: DbSession, study_id: int | None,
                     include_rehearsal: bool) -> list[dict[str, Any]]:  # fmt: skip
    """The export's interaction rows (``chameleons analyze`` reading the database)."""
    study = resolve_study(db, study_id)
    spec = study_from_config(study.config)
    return records(
        table_frame(interactions_table(spec), interaction_rows(db, study, spec, include_rehearsal))
    )
