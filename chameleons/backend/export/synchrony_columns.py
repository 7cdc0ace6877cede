"""The synchrony columns of ``interactions.csv`` (issue 32) and their values: one
definition for the codebook, the datapackage schema, the writers and analysis.R.

The robot's face following the participant's (``sync_*``: did the manipulation run?) and
the participant's following the robot's (``mimicry_*``: an outcome), from the recorded
faces, as docs/science.md ("Synchrony") describes; empty with ``sync_missing`` saying why.
"""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.column_spec import Column
from chameleons.backend.models import InteractionSynchrony, Recording

METHOD = ("windowed lagged cross-correlation of head rotation and facial blendshapes "
          "(rMEA's MEAccf: |Fisher z| per window and lag, averaged over windows and "
          "channels; docs/science.md)")  # fmt: skip
NO_BASELINE = "no_baseline"  # measured, but mimicry_r has no pseudo-pairs to be corrected by
MISSING = ("no_recording, not_computed, unreadable, no_frames, too_short, robot_still, "
           "participant_still, no_common_channels, gaps, no_baseline")  # fmt: skip


def synchrony_columns() -> tuple[Column, ...]:
    return (
        Column("sync_lag_s", "number",
               "Seconds the robot's face followed the participant's, at the peak of their "
               f"{METHOD} over positive lags (robot later): a copy interaction shows its "
               "delay (4 s). Empty: see sync_missing."),
        Column("sync_r", "number",
               "Correlation at that peak: tanh of the mean |Fisher z| (0..1)."),
        Column("sync_surrogate_r", "number",
               "Upper edge of the surrogate band: the 95th percentile of the same peak in "
               "pseudo-pairs (faces that never met; see sync_surrogate_kind). A copy "
               "interaction's sync_r should be above it."),
        Column("sync_check", "string",
               "Copy interactions: ok when the robot followed at the configured delay "
               "(within 0.2 s) and above the surrogate band, else failed (the manipulation "
               "did not run as designed); empty for other conditions.", "ok, failed"),
        Column("sync_check_reason", "string", "What the copy check found, in words."),
        Column("mimicry_lag_s", "number",
               "Seconds the participant's face followed the robot's, at the peak over "
               "negative lags (participant later)."),
        Column("mimicry_r", "number",
               "The participant's mimicry of the robot, surrogate-corrected: tanh(z - mean "
               "z of the pseudo-pairs' peaks), z the mean |Fisher z| at the peak; 0 = no "
               "more than chance."),
        Column("mimicry_raw_r", "number", "The same peak before the correction: tanh(z)."),
        Column("mimicry_p", "number",
               "Share of pseudo-pairs with a peak at least as high, counting this pair: "
               "(1 + k) / (1 + n)."),
        Column("sync_usable_share", "number",
               "Share of the recorded time in which both faces had frames (capture gaps "
               "longer than 0.25 s do not count)."),
        Column("sync_face_source", "string",
               "The capture source most of the participant's frames came from (e.g. "
               "livelink, facecapturex, webcam-browser; empty for recordings that do not "
               "say)."),
        Column("sync_surrogate_kind", "string",
               "between: pseudo-pairs with other participants' faces (rMEA's shuffle); "
               "segments: too few other participants when computed, segment shuffling "
               "within this interaction (rMEA's shuffle_segments); none.",
               "between, segments, none"),
        Column("sync_surrogate_count", "integer", "Pseudo-pairs in the baseline."),
        Column("sync_missing", "string",
               "Why the synchrony values are empty (else empty): not_computed means run "
               "`chameleons synchrony`; no_baseline: sync_lag_s and sync_r were measured, "
               "but mimicry_r (surrogate-corrected) has no pseudo-pairs.", MISSING),
        Column("sync_note", "string", "The reason for empty values, in words."),
    )  # fmt: skip


def synchrony_values(db: DbSession, interaction_ids: Iterable[int]) -> dict[int, dict[str, Any]]:
    """Per interaction, the synchrony columns' values (missing ones with a reason)."""
    ids = list(interaction_ids)
    names = [c.name for c in synchrony_columns()]
    if not ids:
        return {}
    query = select(InteractionSynchrony).where(InteractionSynchrony.interaction_id.in_(ids))
    stored = {row.interaction_id: row for row in db.scalars(query)}
    recorded_query = select(Recording.interaction_id).where(Recording.interaction_id.in_(ids))
    recorded = set(db.scalars(recorded_query.distinct()))
    values: dict[int, dict[str, Any]] = {}
    for interaction_id in ids:
        empty: dict[str, Any] = dict.fromkeys(names)
        row = stored.get(interaction_id)
        if row is None:
            computed = interaction_id in recorded
            empty["sync_missing"] = "not_computed" if computed else "no_recording"
            empty["sync_note"] = ("Recorded, not computed yet: run `chameleons synchrony`."
                                  if computed else "No face recording.")  # fmt: skip
            values[interaction_id] = empty
            continue
        values[interaction_id] = {
            **empty,
            "sync_lag_s": _round(row.sync_lag_s, 3),
            "sync_r": _round(row.sync_r),
            "sync_surrogate_r": _round(row.sync_band_r),
            "sync_check": row.check,
            "sync_check_reason": row.check_reason or None,
            "mimicry_lag_s": _round(row.mimicry_lag_s, 3),
            "mimicry_r": _round(row.mimicry_r),
            "mimicry_raw_r": _round(row.mimicry_raw_r),
            "mimicry_p": _round(row.mimicry_p),
            "sync_usable_share": _round(row.usable_share),
            "sync_face_source": row.face_source,
            "sync_surrogate_kind": row.surrogate_kind,
            "sync_surrogate_count": row.surrogate_count,
            "sync_missing": row.reason or (NO_BASELINE if row.mimicry_r is None else None),
            "sync_note": row.detail or None,
        }
    return values


def _round(value: float | None, digits: int = 4) -> float | None:
    return None if value is None else round(float(value), digits)
