"""The synchrony section of the analysis page and of ``chameleons analyze``: the export's
interaction and score rows through :func:`analyze_synchrony`, so the page, the CLI and an
exported ``interactions.csv`` give the same numbers."""

from __future__ import annotations

from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import analyses
from chameleons.backend.analysis.repository import data_version
from chameleons.backend.export.columns import interactions_table, scores_table
from chameleons.backend.export.frames import records, table_frame
from chameleons.backend.export.rows import interaction_rows
from chameleons.backend.export.scoring import score_rows
from chameleons.backend.export.selection import resolve_study
from chameleons.backend.models import InteractionSynchrony
from chameleons.experiment.stats.analysis import PAPER_REFERENCE
from chameleons.experiment.stats.measures import study_measures
from chameleons.experiment.stats.synchrony.outcomes import SynchronyAnalysis, analyze_synchrony
from chameleons.experiment.study import study_from_config


def study_synchrony(
    db: DbSession, study_id: int | None, include_rehearsal: bool = False,
    view: str = "as_planned", reference: str | None = None,
) -> SynchronyAnalysis | None:  # fmt: skip
    """The analysis page's synchrony section, cached like the page (:mod:`..analysis.cache`)
    under the data version and the newest synchrony result (a recomputation replaces a
    row, and a replaced row gets a new id)."""
    study = resolve_study(db, study_id)
    newest = db.execute(select(func.max(InteractionSynchrony.id))).scalar()
    where = (str(db.get_bind().engine.url), study.id, study.created_at, study.config_hash)
    key = ("synchrony", *where, include_rehearsal, view, reference, data_version(db), newest)
    cached: SynchronyAnalysis | None = analyses.get(key)
    if cached is not None:
        return cached
    result = _computed(db, study_id, include_rehearsal, view, reference)
    analyses.put(key, result)
    return result


def _computed(
    db: DbSession, study_id: int | None, include_rehearsal: bool, view: str,
    reference: str | None,
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
