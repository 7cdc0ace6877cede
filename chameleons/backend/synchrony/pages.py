"""The session page's synchrony plot (PI only)."""

from __future__ import annotations

from fastapi import HTTPException, status
from fastapi.responses import Response

from chameleons.backend.auth.dependencies import CurrentPI
from chameleons.backend.dependencies import DbSession
from chameleons.backend.routing import make_router
from chameleons.backend.synchrony import repository
from chameleons.backend.synchrony.plots import plot_synchrony
from chameleons.experiment.study import study_from_config

router = make_router(tags=["synchrony"])


@router.get("/pi/interactions/{interaction_id}/synchrony.svg")
def synchrony_plot(interaction_id: int, _pi: CurrentPI, db: DbSession) -> Response:
    found = repository.context(db, interaction_id)
    row = repository.stored(db, [interaction_id]).get(interaction_id)
    if found is None or row is None or not row.curves.get("curve"):
        raise HTTPException(status.HTTP_404_NOT_FOUND,
                            f"Interaction {interaction_id} has no synchrony curve.")  # fmt: skip
    condition = study_from_config(found.study.config).condition(found.interaction.condition)
    delay = None
    if condition.behaviour == "copy":
        delay = float(condition.params.get("delay", 4.0))
    title = (f"Interaction {found.interaction.position} ({found.interaction.condition}): "
             f"{row.surrogate_count} {row.surrogate_kind} surrogates")  # fmt: skip
    image = plot_synchrony(row.curves, title, delay=delay)
    return Response(image, media_type="image/svg+xml", headers={"Cache-Control": "no-store"})
