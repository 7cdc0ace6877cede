"""Where the console finds the prompt catalogues, loaded once per app and cached.

Loading validates every row and looks up every file it names (about 0.1 s an actor). A
folder's catalogue is also kept for the process, keyed by the folder and the name, size and
modification time of everything in it: a new app (a test, a restarted server in the same
process) reuses it, and any change in the folder reads it again.

The lead may put ready catalogues on ``app.state.prompt_catalogues`` (actor -> Catalogue);
otherwise they are loaded from ``settings.prompts_dir`` when that setting exists, else from
``<data_dir>/prompts`` when it holds actors, else from the repository's ``prompts/``.
A session's language picks ``<root>/<lang>/<actor>/`` (see ``chameleons.prompts.languages``):
the console then offers only the prompts recorded in that language.
"""

from __future__ import annotations

import os
import threading
from pathlib import Path
from typing import Any

from chameleons.prompts import Catalogue, CatalogueError, load_catalogue
from chameleons.prompts.languages import empty_catalogue, language_directory, missing_groups
from chameleons.prompts.locations import REPOSITORY_PROMPTS, prompts_root

__all__ = [
    "REPOSITORY_PROMPTS",
    "MissingCatalogueError",
    "catalogue_for",
    "missing_in_language",
    "prompts_root",
]
_LOCK = threading.Lock()
_LOADED: dict[tuple[str, str | None], tuple[tuple[tuple[str, int, int], ...], Catalogue]] = {}
_LOADED_LOCK = threading.Lock()


class MissingCatalogueError(LookupError):
    """No usable catalogue for an actor; the message says where the console looked."""


def catalogue_for(state: Any, actor: str, language: str | None = None) -> Catalogue:
    """The actor's catalogue from ``app.state`` (loaded on first use); with ``language``,
    only its prompts in that language (none when it has no catalogue in it)."""
    base = _base_catalogue(state, actor)
    if language is None or language == base.profile.language:
        return base
    kept: dict[tuple[str, str], Catalogue] = getattr(state, "language_catalogues", None) or {}
    loaded = kept.get((language, actor))
    if loaded is not None:  # without the lock: the event loop asks too (is_loaded)
        return loaded
    root = prompts_root(state.settings)
    with _LOCK:
        cache: dict[tuple[str, str], Catalogue] | None = getattr(state, "language_catalogues", None)
        if cache is None:
            cache = state.language_catalogues = {}
        if (language, actor) not in cache:
            directory = language_directory(root, language, actor)
            cache[language, actor] = (
                empty_catalogue(base, language)
                if directory is None
                else _load(directory, actor, language)
            )
        return cache[language, actor]


def missing_in_language(state: Any, actor: str, language: str) -> list[str]:
    """The actor's prompt groups that have no recording in ``language``."""
    base = _base_catalogue(state, actor)
    return missing_groups(base, catalogue_for(state, actor, language))


def is_loaded(state: Any, actor: str, language: str | None = None) -> bool:
    """Whether ``catalogue_for(state, actor, language)`` would answer from memory (no file
    read, no lock held by a loading thread): the event loop may then ask it itself."""
    ready: dict[str, Catalogue] = getattr(state, "prompt_catalogues", None) or {}
    base = ready.get(actor) or (getattr(state, "wizard_catalogues", None) or {}).get(actor)
    if base is None:
        return False
    if language is None or language == base.profile.language:
        return True
    return (language, actor) in (getattr(state, "language_catalogues", None) or {})


def _base_catalogue(state: Any, actor: str) -> Catalogue:
    ready: dict[str, Catalogue] | None = getattr(state, "prompt_catalogues", None)
    if ready is not None and actor in ready:
        return ready[actor]
    cached: dict[str, Catalogue] = getattr(state, "wizard_catalogues", None) or {}
    loaded = cached.get(actor)
    if loaded is not None:  # without the lock, which a thread loading another may hold
        return loaded
    with _LOCK:
        cache: dict[str, Catalogue] | None = getattr(state, "wizard_catalogues", None)
        if cache is None:
            cache = state.wizard_catalogues = {}
        if actor not in cache:
            cache[actor] = _load(prompts_root(state.settings) / actor, actor)
        return cache[actor]


def _fingerprint(directory: Path) -> tuple[tuple[str, int, int], ...]:
    """Every file and folder under ``directory``: relative path, size, modification time."""
    found = []
    for folder, folders, files in os.walk(directory):
        folders.sort()
        for name in sorted(files) + folders:
            path = os.path.join(folder, name)
            try:
                info = os.stat(path)
            except OSError:
                continue  # removed while walking: the next load sees the change
            found.append((os.path.relpath(path, directory), info.st_size, info.st_mtime_ns))
    return tuple(found)


def _load(directory: Path, actor: str, language_folder: str | None = None) -> Catalogue:
    key = (str(directory.resolve()), language_folder)
    fingerprint = _fingerprint(directory)
    with _LOADED_LOCK:
        loaded = _LOADED.get(key)
    if loaded is not None and loaded[0] == fingerprint:
        return loaded[1]
    try:
        catalogue = load_catalogue(directory, language_folder=language_folder)
    except CatalogueError as error:
        raise MissingCatalogueError(
            f"The prompt catalogue of actor {actor!r} in {directory} cannot be used: "
            + "; ".join(error.problems[:3])
        ) from error
    with _LOADED_LOCK:
        _LOADED[key] = (fingerprint, catalogue)
    return catalogue
