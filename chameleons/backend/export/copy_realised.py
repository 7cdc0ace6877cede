"""What a ``copy`` (or ``yoked_copy``) actually drew in each interaction (issue 31): the
columns of ``interactions.csv`` and their values, from the ``robot.copy_draw`` events the
worker reports (one per jittered delay or bout, when the robot first shows it;
docs/design-space.md, "What is recorded").

A draw belongs to the interaction that was running on the booth when the server logged it
(from its ``discussion`` step to ``done``). The realised share of time copying is counted
over whole rest-and-bout cycles: the bouts' seconds over the seconds of the bouts and the
rests before them, so it needs no clock beyond the worker's own draws.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.export.column_spec import Column
from chameleons.backend.models import Event, Session

COPY_DRAW = "robot.copy_draw"


def realised_columns() -> tuple[Column, ...]:
    return (
        Column("realised_delay_mean_s", "number",
               "Mean of the copy delays the worker drew and showed in this interaction (a "
               "jittered delay: one draw per delay_resample_s seconds, or per bout with "
               "intermittent); empty when nothing was drawn (a fixed delay without bouts)."),
        Column("realised_delay_sd_s", "number",
               "Standard deviation (n - 1) of those delays; empty with fewer than two."),
        Column("delay_draws", "integer",
               "How many delays were drawn and shown in this interaction (with intermittent: "
               "one per bout, so a fixed delay is counted too)."),
        Column("copy_bouts", "integer",
               "Intermittent copy: how many bouts started in this interaction; empty "
               "without intermittent."),
        Column("copy_fraction", "number",
               "Intermittent copy: the share of time the robot copied, over the bouts that "
               "started in this interaction and the rests before them (bout seconds / "
               "(bout + rest seconds)); its expectation is bout_s / (bout_s + 1 / "
               "rate_per_s). Empty without intermittent."),
    )  # fmt: skip


def realised_values(db: DbSession, study_id: int) -> dict[int, dict[str, Any]]:
    """Interaction id -> the realised columns, for the interactions of one study that drew
    anything (the others have none: their columns stay empty)."""
    query = (
        select(Event.interaction_id, Event.payload)
        .join(Session, Session.id == Event.session_id)
        .where(Session.study_id == study_id, Event.kind == COPY_DRAW,
               Event.interaction_id.is_not(None))
        .order_by(Event.id)
    )  # fmt: skip
    draws: dict[int, list[dict[str, Any]]] = {}
    for interaction_id, payload in db.execute(query):
        if isinstance(payload, dict) and interaction_id is not None:
            draws.setdefault(int(interaction_id), []).append(payload)
    return {interaction_id: summarise(found) for interaction_id, found in draws.items()}


def summarise(draws: Iterable[dict[str, Any]]) -> dict[str, Any]:
    """The realised columns of one interaction's ``copy_draw`` payloads."""
    delays: list[float] = []
    copying = cycle = 0.0
    bouts = 0
    for draw in draws:
        delay = _number(draw.get("delay_s"))
        if delay is not None:
            delays.append(delay)
        bout_s, rest_s = _number(draw.get("bout_s")), _number(draw.get("rest_s"))
        if draw.get("bout") is not None and bout_s is not None and rest_s is not None:
            bouts += 1
            copying += bout_s
            cycle += bout_s + rest_s
    mean = sum(delays) / len(delays) if delays else None
    sd = (math.sqrt(sum((d - mean) ** 2 for d in delays) / (len(delays) - 1))
          if mean is not None and len(delays) > 1 else None)  # fmt: skip
    return {
        "realised_delay_mean_s": None if mean is None else round(mean, 4),
        "realised_delay_sd_s": None if sd is None else round(sd, 4),
        "delay_draws": len(delays) or None,
        "copy_bouts": bouts or None,
        "copy_fraction": round(copying / cycle, 4) if cycle > 0 else None,
    }


def _number(value: Any) -> float | None:
    if isinstance(value, bool) or not isinstance(value, int | float):
        return None
    return float(value) if math.isfinite(value) else None
