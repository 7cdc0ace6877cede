"""Prompt catalogues per language.

``prompts/<actor>/`` is the actor's catalogue in its own language (``language:`` in its
``actor.yaml``, English when it says nothing); ``prompts/<lang>/<actor>/`` holds the same
actor's prompts in another language, with the same group names where a prompt exists in
both (a language folder needs only the prompts recorded in it). A session in a language
gets only that language's prompts; the groups it lacks are listed so the console can say
which prompts have no recording in it.
"""

from __future__ import annotations

from pathlib import Path

from chameleons.prompts.catalogue import Catalogue
from chameleons.prompts.manifest import MANIFEST_NAME


def language_directory(root: Path, language: str, actor: str) -> Path | None:
    """``root/<language>/<actor>`` when it holds a manifest."""
    directory = root / language / actor
    return directory if (directory / MANIFEST_NAME).is_file() else None


def catalogue_languages(root: Path, base: Catalogue) -> list[str]:
    """Every language the actor has prompts in: the base catalogue's first."""
    others = sorted(
        path.name
        for path in root.iterdir()
        if path.is_dir() and language_directory(root, path.name, base.actor) is not None
    ) if root.is_dir() else []  # fmt: skip
    return [base.profile.language, *[lang for lang in others if lang != base.profile.language]]


def empty_catalogue(base: Catalogue, language: str) -> Catalogue:
    """No prompts in ``language``: the console shows none, and says so."""
    return Catalogue(base.actor, base.directory / language, base.profile, (),
                     language_folder=language)  # fmt: skip


def missing_groups(base: Catalogue, translated: Catalogue) -> list[str]:
    """Groups of the base catalogue without a prompt in the other language, in order."""
    have = {group.name for group in translated.groups()}
    return [group.name for group in base.groups() if group.name not in have]
