"""The experiment core's view of a stored study, rebuilt from its config snapshot.

Rebuilding validates the whole snapshot, so the result is cached by the config hash (a
snapshot never changes once stored: a changed config is a new study row).
"""

from __future__ import annotations

import threading

from chameleons.backend.models import Study as StudyRow
from chameleons.experiment.model import Study
from chameleons.experiment.study import study_from_config

_CACHE: dict[str, Study] = {}
_LOCK = threading.Lock()


def spec_of(study: StudyRow) -> Study:
    with _LOCK:
        cached = _CACHE.get(study.config_hash)
    if cached is not None:
        return cached
    spec = study_from_config(study.config)
    with _LOCK:
        _CACHE[study.config_hash] = spec
    return spec


def item_key(item_id: str) -> str:
    """An item id as stored in a plan row may be qualified (``lunar:water``); the task's own
    id is the part after the colon."""
    return item_id.rsplit(":", 1)[-1]


def item_name(spec: Study, task_id: str, item_id: str) -> str:
    return spec.task(task_id).item(item_key(item_id)).name
