"""Prompt catalogues per language.

``prompts/<actor>/`` is the actor's catalogue in its own language (``language:`` in its
``actor.yaml``, English when it says nothing); ``prompts/<lang>/<actor>/`` holds the same
actor's prompts in another language, with the same group names where a prompt exists in
both (a language folder needs only the prompts recorded in it). A session in a language
gets only that language's prompts; the groups it lacks are listed so the console can say
which prompts have no recording in it.

A language is *complete* for an actor (:func:`language_gap`) when every group of the
actor's main catalogue that the study can need has a prompt in it, recorded wherever the
main catalogue's is: a session in that language then voices as many prompts as one in the
main language. The server refuses a real session in an incomplete language before it
starts (a wizard must never word a prompt himself in a Wizard-of-Oz study).
"""

from __future__ import annotations

from collections.abc import Callable, Collection, Mapping
from dataclasses import dataclass
from pathlib import Path

from chameleons.prompts.catalogue import Catalogue
from chameleons.prompts.manifest import MANIFEST_NAME
from chameleons.prompts.model import PromptGroup

Needed = Callable[[PromptGroup], bool]
EXAMPLES = 5  # groups named in a sentence; the console and the CLI list them all


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


@dataclass(frozen=True)
class LanguageGap:
    """What an actor's catalogue in ``language`` lacks against its main catalogue."""

    actor: str
    language: str
    needed: int  # groups of the main catalogue the study can need
    missing: tuple[str, ...]  # of those, the groups with no prompt in ``language``
    unrecorded: tuple[str, ...]  # prompts in ``language`` without audio where main has it

    @property
    def complete(self) -> bool:
        return not self.missing and not self.unrecorded

    def sentence(self) -> str:
        """One sentence for staff, e.g. "actor f1 has no sv prompt for 234 of its 277
        prompt groups (lunar_water_move_up, ...)"."""
        parts = []
        if self.missing:
            parts.append(f"no {self.language} prompt for {len(self.missing)} of its "
                         f"{self.needed} prompt groups ({_examples(self.missing)})")  # fmt: skip
        if self.unrecorded:
            parts.append(f"{len(self.unrecorded)} {self.language} prompts without a "
                         f"recording ({_examples(self.unrecorded)})")  # fmt: skip
        return f"actor {self.actor} has " + " and ".join(parts) if parts else ""


def _examples(names: tuple[str, ...]) -> str:
    more = len(names) - EXAMPLES
    return ", ".join(names[:EXAMPLES]) + (f", and {more} more" if more > 0 else "")


def study_needs(tasks: Mapping[str, Collection[str]], robot_names: Collection[str]) -> Needed:
    """Whether a group can be needed by a study with these tasks (task id -> item ids) and
    robot names: groups about other tasks, items or names cannot."""

    def needed(group: PromptGroup) -> bool:
        prompt = group.prompts[0]
        if prompt.robot_name is not None and prompt.robot_name not in robot_names:
            return False
        if prompt.task is None:
            return True
        items = tasks.get(prompt.task)
        return items is not None and all(
            item is None or item in items for item in (prompt.item, prompt.other_item)
        )

    return needed


def language_gap(
    base: Catalogue, translated: Catalogue, language: str, needed: Needed | None = None
) -> LanguageGap:
    """What ``translated`` (the actor's catalogue in ``language``) lacks against ``base``
    (its main catalogue), among the groups ``needed`` keeps (all by default)."""
    wanted = [group for group in base.groups() if needed is None or needed(group)]
    have = {group.name: group for group in translated.groups()}
    missing = tuple(group.name for group in wanted if group.name not in have)
    unrecorded = tuple(
        prompt.id
        for group in wanted
        if group.name in have and any(p.audio is not None for p in group.prompts)
        for prompt in have[group.name].prompts
        if prompt.audio is None
    )
    return LanguageGap(base.actor, language, len(wanted), missing, unrecorded)
