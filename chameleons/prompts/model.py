"""The prompt types: one pre-recorded (or not yet recorded) robot utterance and its actor.

Plain frozen dataclasses with no I/O, shared by the server (wizard console) and the worker
(playback).
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import PurePosixPath

# Speaking rate used to estimate how long a prompt without audio takes to say.
WORDS_PER_SECOND = 2.6
# Even "Hmm." takes a moment; never estimate less than this.
MIN_DURATION_SECONDS = 0.6
_WORD = re.compile(r"[\w'\u2019-]+")


class Stage(StrEnum):
    """Where in an interaction a prompt is used; the console groups its buttons by stage."""

    INTRO = "intro"
    SCENARIO = "scenario"
    ITEM_DESCRIPTION = "item_description"
    ITEM_QUESTION = "item_question"
    RANK_INSTRUCTION = "rank_instruction"
    SUGGESTION = "suggestion"
    ACKNOWLEDGEMENT = "acknowledgement"
    REPEAT = "repeat"
    CANNOT_ANSWER = "cannot_answer"
    TRANSITION = "transition"
    CLOSING = "closing"


# Stages whose prompts only make sense for one item of one task.
ITEM_STAGES = frozenset({Stage.ITEM_DESCRIPTION, Stage.ITEM_QUESTION, Stage.SUGGESTION})


class SuggestionKind(StrEnum):
    """How a suggestion prompt phrases the move "item from rank r to rank t"."""

    ABOVE = "above"  # "put X above Y": Y is the item now at the target rank
    MAKE_FIRST = "make_first"  # "put X at the top": target rank 1
    MOVE_UP = "move_up"  # "move X up": fits any move up, the fallback
    BELOW = "below"  # "put X below Y": a move down; Y is the item now at the target rank
    MAKE_LAST = "make_last"  # "put X at the bottom": target the last rank
    MOVE_DOWN = "move_down"  # "move X down": fits any move down, the fallback

    @property
    def down(self) -> bool:
        return self in (SuggestionKind.BELOW, SuggestionKind.MAKE_LAST, SuggestionKind.MOVE_DOWN)


# Group name endings that say how a suggestion prompt phrases its move (prompts/README.md).
MAKE_FIRST_SUFFIXES = ("_first", "_top")
MAKE_LAST_SUFFIXES = ("_last", "_bottom")
MOVE_DOWN_SUFFIXES = ("_down",)
BELOW_MARKER = "_below_"  # with other_item: "put X below other_item"


def estimate_duration(text: str) -> float:
    """Seconds it takes to say ``text`` at about 2.6 words per second."""
    words = len(_WORD.findall(text))
    return round(max(MIN_DURATION_SECONDS, words / WORDS_PER_SECOND), 2)


def item_ref(task: str, item: str) -> str:
    """Item ids are unique within a task only: ``lunar:water`` names one item."""
    return f"{task}:{item}"


@dataclass(frozen=True, slots=True)
class Prompt:
    """One row of an actor's manifest. ``audio``/``lipsync`` are relative to the actor dir."""

    id: str
    stage: Stage
    group: str
    text: str
    task: str | None = None
    item: str | None = None
    other_item: str | None = None
    robot_name: str | None = None
    audio: PurePosixPath | None = None
    lipsync: PurePosixPath | None = None
    estimated_duration: float = 0.0
    line: int = field(default=0, compare=False)  # manifest line, for messages

    @property
    def item_ref(self) -> str | None:
        if self.task is None or self.item is None:
            return None
        return item_ref(self.task, self.item)

    @property
    def suggestion_kind(self) -> SuggestionKind | None:
        if self.stage is not Stage.SUGGESTION:
            return None
        if self.other_item is not None:
            return SuggestionKind.BELOW if BELOW_MARKER in self.group else SuggestionKind.ABOVE
        for suffixes, kind in (
            (MAKE_FIRST_SUFFIXES, SuggestionKind.MAKE_FIRST),
            (MAKE_LAST_SUFFIXES, SuggestionKind.MAKE_LAST),
            (MOVE_DOWN_SUFFIXES, SuggestionKind.MOVE_DOWN),
        ):
            if self.group.endswith(suffixes):
                return kind
        return SuggestionKind.MOVE_UP


@dataclass(frozen=True, slots=True)
class PromptGroup:
    """Interchangeable variants: the console plays one of them, picked at random."""

    name: str
    prompts: tuple[Prompt, ...]

    @property
    def stage(self) -> Stage:
        return self.prompts[0].stage

    @property
    def suggestion_kind(self) -> SuggestionKind | None:
        return self.prompts[0].suggestion_kind


@dataclass(frozen=True, slots=True)
class ActorProfile:
    """The robot personality of one actor (``actor.yaml``); ``voice`` is for synthesisers."""

    actor: str
    display_name: str
    gender: str | None = None
    personality: str | None = None
    description: str = ""
    voice: Mapping[str, str | int | float] = field(default_factory=dict)
    # The language the actor's prompts are in (prompts/<actor>/: English unless it says;
    # prompts/<lang>/<actor>/ holds the same actor's prompts in another language).
    language: str = "en"
