"""One actor's validated prompts, with the lookups the wizard console and playback need."""

from __future__ import annotations

import random
import wave
from collections.abc import Iterable, Sequence
from pathlib import Path, PurePosixPath

from chameleons.prompts.model import (
    ActorProfile,
    Prompt,
    PromptGroup,
    Stage,
    SuggestionKind,
)


class Catalogue:
    """All prompts of one actor, in manifest order. Build it with ``load_catalogue``."""

    def __init__(
        self,
        actor: str,
        directory: Path,
        profile: ActorProfile,
        prompts: Iterable[Prompt],
        *,
        language_folder: str | None = None,
    ) -> None:
        self.actor = actor
        self.directory = directory
        # The language folder the catalogue was read from (``prompts/<lang>/<actor>/``), or
        # None for the actor's own folder: media URLs carry it, so the robot is served the
        # file of this catalogue and not the same-named one of the actor's main language.
        self.language_folder = language_folder
        self.profile = profile
        self.prompts: tuple[Prompt, ...] = tuple(prompts)
        self._by_id = {prompt.id: prompt for prompt in self.prompts}
        grouped: dict[str, list[Prompt]] = {}
        for prompt in self.prompts:
            grouped.setdefault(prompt.group, []).append(prompt)
        self._groups = {name: PromptGroup(name, tuple(ps)) for name, ps in grouped.items()}

    def __len__(self) -> int:
        return len(self.prompts)

    def __repr__(self) -> str:
        return f"Catalogue(actor={self.actor!r}, prompts={len(self.prompts)})"

    def by_id(self, prompt_id: str) -> Prompt:
        """The prompt with this id; KeyError when there is none."""
        return self._by_id[prompt_id]

    def get(self, prompt_id: str) -> Prompt | None:
        return self._by_id.get(prompt_id)

    def by_stage(self, stage: Stage | str) -> tuple[Prompt, ...]:
        return tuple(p for p in self.prompts if p.stage == stage)

    def group(self, name: str) -> PromptGroup:
        """The variant group with this name; KeyError when there is none."""
        return self._groups[name]

    def groups(self, stage: Stage | str | None = None) -> tuple[PromptGroup, ...]:
        """Variant groups in manifest order, optionally only those of one stage."""
        return tuple(g for g in self._groups.values() if stage is None or g.stage == stage)

    def for_item(self, task: str, item: str) -> tuple[Prompt, ...]:
        """Every prompt about this item (description, question, suggestions moving it)."""
        return tuple(p for p in self.prompts if p.task == task and p.item == item)

    def suggestion_prompts(
        self,
        task: str,
        item: str,
        to_rank: int,
        other_item: str | None = None,
        *,
        down: bool = False,
        last_rank: int = 0,
    ) -> list[PromptGroup]:
        """Groups that phrase "move ``item`` to ``to_rank``", best first.

        ``other_item`` is the item now at ``to_rank`` (the one ``item`` goes above, or below
        when the move is ``down``). Up: "put item above other_item", then "make item first"
        (only when ``to_rank`` is 1), then the generic "move item up". Down: "put item below
        other_item", "make item last" (only when ``to_rank`` is ``last_rank``), "move item
        down". Empty when the catalogue has none of them.
        """
        wanted: list[tuple[SuggestionKind, str | None]] = []
        if other_item is not None:
            wanted.append((SuggestionKind.BELOW if down else SuggestionKind.ABOVE, other_item))
        if down and to_rank == last_rank:
            wanted.append((SuggestionKind.MAKE_LAST, None))
        if not down and to_rank == 1:
            wanted.append((SuggestionKind.MAKE_FIRST, None))
        wanted.append((SuggestionKind.MOVE_DOWN if down else SuggestionKind.MOVE_UP, None))
        candidates = [
            g
            for g in self.groups(Stage.SUGGESTION)
            if g.prompts[0].task == task and g.prompts[0].item == item
        ]
        return [
            g
            for kind, other in wanted
            for g in candidates
            if g.suggestion_kind is kind and g.prompts[0].other_item == other
        ]

    def audio_file(self, prompt: Prompt) -> Path | None:
        """Absolute path of the prompt's audio, or None when it has none yet."""
        return self._resolve(prompt.audio)

    def lipsync_file(self, prompt: Prompt) -> Path | None:
        return self._resolve(prompt.lipsync)

    def duration(self, prompt: Prompt) -> float:
        """The prompt's length in seconds: from a WAV file when it has one, else estimated."""
        path = self.audio_file(prompt)
        measured = _wav_duration(path) if path is not None else None
        return prompt.estimated_duration if measured is None else measured

    def _resolve(self, relative: PurePosixPath | None) -> Path | None:
        return None if relative is None else self.directory.joinpath(*relative.parts)


def _wav_duration(path: Path) -> float | None:
    if path.suffix.lower() != ".wav":
        return None
    try:
        with wave.open(str(path), "rb") as reader:
            return reader.getnframes() / reader.getframerate()
    except (OSError, EOFError, wave.Error):
        return None  # unreadable: fall back to the estimate rather than fail a session


def pick_variant(
    group: PromptGroup | Sequence[Prompt],
    last_id: str | None = None,
    rng: random.Random | None = None,
) -> Prompt:
    """A random variant of the group, never ``last_id`` again when there is another choice."""
    prompts = group.prompts if isinstance(group, PromptGroup) else tuple(group)
    if not prompts:
        raise ValueError("cannot pick a variant of an empty group")
    fresh = [p for p in prompts if p.id != last_id] or list(prompts)
    return (rng or random).choice(fresh)
