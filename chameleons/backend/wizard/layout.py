"""The console's prompt buttons for one interaction: sections, labels and keyboard shortcuts.

Pure: a catalogue and the interaction's facts in, JSON-able sections out. The keyboard
scheme (shown on every button and in the console's help):

- items, in the order the participant was shown them: ``1``..``9`` describe item n,
  ``Shift`` + ``1``..``9`` ask the participant's opinion of item n;
- script lines (intro, scenario, transitions, rank instruction, closing) and replies
  (acknowledgements, repeat, "I can't answer that"): one letter each, mnemonic where the
  catalogue uses the demo group names, otherwise the first free letter;
- reserved for the console itself: ``A`` accept, ``D`` decline, ``U`` undo, ``M`` ``,``
  ``.`` the current suggestion's phrasings, ``Space``/``Escape`` stop, ``/`` search.
"""

from __future__ import annotations

import string
from collections.abc import Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from chameleons.prompts import Catalogue, PromptGroup, Stage

Button = dict[str, Any]
Section = dict[str, Any]

SCRIPT_STAGES = (Stage.INTRO, Stage.SCENARIO, Stage.TRANSITION, Stage.RANK_INSTRUCTION,
                 Stage.CLOSING)  # fmt: skip
REPLY_STAGES = (Stage.ACKNOWLEDGEMENT, Stage.REPEAT, Stage.CANNOT_ANSWER)
RESERVED_LETTERS = frozenset("ADUM")
SUGGESTION_KEYS = (("KeyM", "M"), ("Comma", ","), ("Period", "."))
PREFERRED_LETTERS: Mapping[str, str] = {
    "first_item": "F", "next_item": "T", "review_ranking": "V", "start_suggestions": "P",
    "rank_instruction": "K", "closing": "L",
    "ack_yes": "Y", "ack_no": "N", "ack_okay": "O", "ack_i_see": "S",
    "ack_good_point": "G", "ack_hmm": "H", "repeat": "R", "cannot_answer": "C",
}  # fmt: skip
STAGE_LETTERS: Mapping[Stage, str] = {Stage.INTRO: "I", Stage.SCENARIO: "E"}
SCRIPT_LABELS: Mapping[Stage, str] = {
    Stage.INTRO: "Introduce",
    Stage.SCENARIO: "Scenario",
    Stage.RANK_INSTRUCTION: "Rank on the phone",
    Stage.CLOSING: "Closing (to questionnaire)",
}
SHORT_TEXT = 22  # a reply whose text is this short is its own label ("Good point.")


@dataclass(frozen=True)
class InteractionFacts:
    """What the layout needs to know about the interaction being run."""

    task: str
    items: Sequence[str]  # item ids in the order the participant was shown them
    item_names: Mapping[str, str]
    robot_name: str


def shortcut(code: str, label: str, *, shift: bool = False) -> dict[str, Any]:
    """A key as the browser reports it (``KeyboardEvent.code``) and how the button shows it."""
    return {"code": code, "shift": shift, "label": f"\u21e7{label}" if shift else label}


def button(group: PromptGroup, label: str, catalogue: Catalogue) -> Button:
    first = group.prompts[0]
    return {
        "group": group.name,
        "label": label,
        "text": first.text,
        "variants": [p.text for p in group.prompts],
        "stage": group.stage.value,
        "item": first.item,
        "other_item": first.other_item,
        "kind": group.suggestion_kind.value if group.suggestion_kind else None,
        "duration": round(max(catalogue.duration(p) for p in group.prompts), 2),
        "has_audio": all(p.audio is not None for p in group.prompts),
        "shortcut": None,
    }


def sections(catalogue: Catalogue, facts: InteractionFacts) -> list[Section]:
    """All prompt sections for the interaction, with shortcuts assigned."""
    result: list[Section] = [
        {"id": "script", "title": "Script", "buttons": script_buttons(catalogue, facts)},
        {"id": "items", "title": "Items (order shown)", "buttons": item_buttons(catalogue, facts)},
        {"id": "replies", "title": "Replies", "buttons": reply_buttons(catalogue)},
        {
            "id": "suggestions",
            "title": "Suggestion prompts",
            "buttons": suggestion_buttons(catalogue, facts),
        },
    ]
    assign_letters([b for s in result if s["id"] in ("script", "replies") for b in s["buttons"]])
    return result


def script_buttons(catalogue: Catalogue, facts: InteractionFacts) -> list[Button]:
    buttons: list[Button] = []
    for stage in SCRIPT_STAGES:
        for group in _fitting(catalogue.groups(stage), facts):
            buttons.append(button(group, _script_label(group), catalogue))
    return buttons


def item_buttons(catalogue: Catalogue, facts: InteractionFacts) -> list[Button]:
    buttons: list[Button] = []
    for number, item in enumerate(facts.items, start=1):
        name = facts.item_names.get(item, item)
        for stage, verb, shift in ((Stage.ITEM_DESCRIPTION, "Describe", False),
                                   (Stage.ITEM_QUESTION, "Ask about", True)):  # fmt: skip
            for group in _item_groups(catalogue, stage, facts.task, item):
                entry = button(group, f"{verb} {name}", catalogue)
                entry["position"] = number
                if number <= 9:
                    entry["shortcut"] = shortcut(f"Digit{number}", str(number), shift=shift)
                buttons.append(entry)
    return buttons


def reply_buttons(catalogue: Catalogue) -> list[Button]:
    return [
        button(group, _reply_label(group), catalogue)
        for stage in REPLY_STAGES
        for group in catalogue.groups(stage)
    ]


def suggestion_buttons(catalogue: Catalogue, facts: InteractionFacts) -> list[Button]:
    """Every suggestion phrasing about this interaction's items (the console highlights the
    ones that match the current suggestion)."""
    shown = set(facts.items)
    buttons: list[Button] = []
    for item in facts.items:
        name = facts.item_names.get(item, item)
        for group in _item_groups(catalogue, Stage.SUGGESTION, facts.task, item):
            other = group.prompts[0].other_item
            if other is not None and other not in shown:
                continue
            entry = button(group, f"{name}: {_suggestion_label(group, facts)}", catalogue)
            buttons.append(entry)
    return buttons


def suggestion_groups(
    catalogue: Catalogue, task: str, item: str, to_rank: int, ranking: Sequence[str]
) -> list[str]:
    """Group names phrasing "move ``item`` to ``to_rank``" in ``ranking``, best first (a move
    down when ``item`` now sits above ``to_rank``)."""
    other = ranking[to_rank - 1] if 1 <= to_rank <= len(ranking) else None
    down = item in ranking and ranking.index(item) + 1 < to_rank
    groups = catalogue.suggestion_prompts(
        task, item, to_rank, other if other != item else None, down=down,
        last_rank=len(ranking),
    )  # fmt: skip
    return [group.name for group in groups]


def assign_letters(buttons: Iterable[Button]) -> None:
    """Give each button its preferred letter, else the first free letter of its label."""
    taken = set(RESERVED_LETTERS)
    waiting: list[Button] = []
    for entry in buttons:
        letter = PREFERRED_LETTERS.get(entry["group"]) or STAGE_LETTERS.get(Stage(entry["stage"]))
        if letter and letter not in taken:
            taken.add(letter)
            entry["shortcut"] = shortcut(f"Key{letter}", letter)
        else:
            waiting.append(entry)
    for entry in waiting:
        candidates = [c.upper() for c in entry["label"] if c.isalpha()] + list(
            string.ascii_uppercase
        )
        letter = next((c for c in candidates if c in string.ascii_uppercase and c not in taken),
                      None)  # fmt: skip
        if letter is not None:
            taken.add(letter)
            entry["shortcut"] = shortcut(f"Key{letter}", letter)


def _fitting(groups: Iterable[PromptGroup], facts: InteractionFacts) -> list[PromptGroup]:
    """Groups usable in this interaction: for its task (or any) and its robot (or any)."""
    return [
        g
        for g in groups
        if g.prompts[0].task in (None, facts.task)
        and g.prompts[0].robot_name in (None, facts.robot_name)
    ]


def _item_groups(catalogue: Catalogue, stage: Stage, task: str, item: str) -> list[PromptGroup]:
    return [
        g
        for g in catalogue.groups(stage)
        if g.prompts[0].task == task and g.prompts[0].item == item
    ]


def _humanize(name: str) -> str:
    words = name.replace("_", " ").strip()
    return words[:1].upper() + words[1:]


def _script_label(group: PromptGroup) -> str:
    fixed = SCRIPT_LABELS.get(group.stage)
    if fixed is None:
        return _humanize(group.name)
    robot = group.prompts[0].robot_name
    return f"{fixed} ({robot})" if group.stage is Stage.INTRO and robot else fixed


def _reply_label(group: PromptGroup) -> str:
    text = group.prompts[0].text
    return text if len(text) <= SHORT_TEXT else _humanize(group.name.removeprefix("ack_"))


SUGGESTION_LABELS = {
    "make_first": "make first", "move_up": "move up", "make_last": "make last",
    "move_down": "move down",
}  # fmt: skip


def _suggestion_label(group: PromptGroup, facts: InteractionFacts) -> str:
    other = group.prompts[0].other_item
    kind = group.suggestion_kind
    if other is not None:
        where = "below" if kind is not None and kind.down else "above"
        return f"{where} {facts.item_names.get(other, other)}"
    return SUGGESTION_LABELS.get(kind.value if kind is not None else "", "move up")
