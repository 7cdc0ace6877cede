"""Where the console finds the prompt catalogues, loaded once per app and cached.

The lead may put ready catalogues on ``app.state.prompt_catalogues`` (actor -> Catalogue);
otherwise they are loaded from ``settings.prompts_dir`` when that setting exists, else from
``<data_dir>/prompts`` when it holds actors, else from the repository's ``prompts/``.
"""

from __future__ import annotations

import threading
from pathlib import Path
from typing import Any

from chameleons.prompts import Catalogue, CatalogueError, load_catalogue
from chameleons.prompts.locations import REPOSITORY_PROMPTS, prompts_root

__all__ = ["REPOSITORY_PROMPTS", "MissingCatalogueError", "catalogue_for", "prompts_root"]
_LOCK = threading.Lock()


class MissingCatalogueError(LookupError):
    """No usable catalogue for an actor; the message says where the console looked."""


def catalogue_for(state: Any, actor: str) -> Catalogue:
    """The actor's catalogue from ``app.state`` (loaded on first use)."""
    ready: dict[str, Catalogue] | None = getattr(state, "prompt_catalogues", None)
    if ready is not None and actor in ready:
        return ready[actor]
    with _LOCK:
        cache: dict[str, Catalogue] | None = getattr(state, "wizard_catalogues", None)
        if cache is None:
            cache = state.wizard_catalogues = {}
        if actor not in cache:
            cache[actor] = _load(prompts_root(state.settings), actor)
        return cache[actor]


def _load(root: Path, actor: str) -> Catalogue:
    directory = root / actor
    try:
        return load_catalogue(directory)
    except CatalogueError as error:
        raise MissingCatalogueError(
            f"The prompt catalogue of actor {actor!r} in {directory} cannot be used: "
            + "; ".join(error.problems[:3])
        ) from error
