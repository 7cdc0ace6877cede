"""Power simulations for the PI page and the preregistration download.

A simulation takes seconds to minutes (statsmodels fits one model per simulated study), so
it runs in a spawned worker process: the server's interpreter stays free for the wizard
consoles and robot displays. One simulation runs at a time; results are cached per study
and request, so the preregistration download reuses the table the page just showed.
"""

from __future__ import annotations

import asyncio
import multiprocessing
import threading
from concurrent.futures import ProcessPoolExecutor
from datetime import UTC, datetime
from typing import Any

from sqlalchemy import func, select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.analysis.cache import ResultCache
from chameleons.backend.models import PlanRow, Study
from chameleons.experiment.prereg import PlanFacts, preregistration
from chameleons.experiment.stats.power_service import PowerRequest, run_power
from chameleons.experiment.study import study_from_config

_running = threading.Lock()
results = ResultCache(max_entries=8)


class PowerBusyError(RuntimeError):
    """Another power simulation is running."""


def simulate_study(config: dict[str, Any], request: PowerRequest) -> dict[str, Any]:
    """Runs in the worker process: the study from its stored configuration."""
    return run_power(study_from_config(config), request).to_dict()


async def power_result(study: Study, request: PowerRequest) -> dict[str, Any]:
    """The simulation's result (cached, else computed in a worker process)."""
    key = (study.id, study.config_hash, repr(request))
    cached = results.get(key)
    if cached is not None:
        return cached  # type: ignore[no-any-return]
    if not _running.acquire(blocking=False):
        raise PowerBusyError("another power simulation is running: try again when it is done")
    try:
        context = multiprocessing.get_context("spawn")
        loop = asyncio.get_running_loop()
        with ProcessPoolExecutor(max_workers=1, mp_context=context) as pool:
            result = await loop.run_in_executor(pool, simulate_study, study.config, request)
    finally:
        _running.release()
    results.put(key, result)
    return result


def plan_facts(db: DbSession, study: Study) -> PlanFacts:
    rows = db.scalar(select(func.count()).select_from(PlanRow).where(PlanRow.study_id == study.id))
    return PlanFacts(
        seed=study.plan_seed,
        rows=int(rows or 0),
        config_hash=study.config_hash,
        created=datetime.now(UTC).date().isoformat(),
    )


def preregistration_markdown(db: DbSession, study: Study, power: dict[str, Any] | None) -> str:
    return preregistration(study_from_config(study.config), plan_facts(db, study), power)
