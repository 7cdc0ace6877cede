"""Reading a study document's questionnaires (``questionnaires:``) into model values: their
scales, items and options, problems to the reader (see docs/designing-a-study.md)."""

from __future__ import annotations

from typing import Any, cast

from chameleons.experiment.model import Choice, ItemType, Phase, Questionnaire, QuestionnaireItem
from chameleons.experiment.reader import SNAKE, Reader, join, optional_text

ITEM_TYPES = ("differential", "agreement", "text", "choice", "robot")
PHASES = ("before", "interaction", "final")
# Which keys each item type needs (beyond id and type) and may have.
ITEM_KEYS: dict[str, tuple[list[str], list[str]]] = {
    "differential": (["left", "right"], ["text", "reverse"]),
    "agreement": (["text"], ["reverse"]),
    "text": (["text"], []),
    "choice": (["text", "options"], []),
    "robot": (["text"], []),
}


def read_questionnaires(reader: Reader, node: object) -> tuple[Questionnaire, ...]:
    questionnaires = []
    for qid, body, place in reader.keyed(node, "questionnaires", SNAKE):
        reader.check_keys(body, place, ["version", "phase", "items"], ["title", "scale"])
        phase = body.get("phase")
        if phase not in PHASES:
            reader.problem(join(place, "phase"), f"must be one of {list(PHASES)}, got {phase!r}")
        scale_place = join(place, "scale")
        scale = reader.mapping(body.get("scale", {}), scale_place)
        reader.check_keys(scale, scale_place, [], ["points", "low", "high"])
        items = _read_questions(reader, body.get("items", []), join(place, "items"))
        for index, item in enumerate(items):
            if item.type == "robot" and phase != "final":
                where = join(join(join(place, "items"), index), "type")
                reader.problem(where, "a robot item belongs in a final questionnaire")
        points = reader.integer(scale, "points", scale_place, default=7, minimum=2, maximum=11)
        questionnaires.append(
            Questionnaire(
                id=qid,
                version=reader.text(body, "version", place),
                title=reader.text(body, "title", place, default=qid),
                phase=cast(Phase, phase if phase in PHASES else "interaction"),
                points=points,
                low=optional_text(reader, scale, "low", scale_place),
                high=optional_text(reader, scale, "high", scale_place),
                items=items,
            )
        )
    return tuple(questionnaires)


def _read_questions(reader: Reader, node: object, path: str) -> tuple[QuestionnaireItem, ...]:
    questions: list[QuestionnaireItem] = []
    for index, element in enumerate(reader.sequence(node, path)):
        place = join(path, index)
        body = reader.mapping(element, place)
        kind = body.get("type")
        if kind in ITEM_TYPES:
            needed, allowed = ITEM_KEYS[kind]
            optional = ["identifying", "required", *allowed]
            reader.check_keys(body, place, ["id", "type", *needed], optional)
        else:  # which other keys belong depends on the type: report only the type
            reader.problem(join(place, "type"), f"must be one of {list(ITEM_TYPES)}, got {kind!r}")
            kind = "text"
        question = QuestionnaireItem(
            id=reader.identifier(body.get("id"), join(place, "id"), SNAKE),
            type=cast(ItemType, kind),
            text=optional_text(reader, body, "text", place),
            left=optional_text(reader, body, "left", place),
            right=optional_text(reader, body, "right", place),
            reverse=reader.boolean(body, "reverse", place, default=False),
            identifying=reader.boolean(body, "identifying", place, default=kind == "text"),
            required=reader.boolean(body, "required", place, default=kind != "text"),
            options=_read_options(reader, body, place) if kind == "choice" else (),
        )
        if any(q.id == question.id for q in questions):
            reader.problem(join(place, "id"), f"question id {question.id!r} used twice")
        questions.append(question)
    if not questions:
        reader.problem(path, "needs at least one question")
    return tuple(questions)


def _read_options(reader: Reader, body: dict[str, Any], place: str) -> tuple[Choice, ...]:
    """``options: [{id: yes, label: Yes}, ...]`` (a plain text is its own label with a
    snake_case id made from it)."""
    path = join(place, "options")
    options: list[Choice] = []
    for index, element in enumerate(reader.sequence(body.get("options", []), path)):
        where = join(path, index)
        if isinstance(element, str):
            element = {"id": "_".join(element.lower().split()), "label": element}
        option = reader.mapping(element, where)
        reader.check_keys(option, where, ["id", "label"], [])
        choice = Choice(
            reader.identifier(option.get("id"), join(where, "id"), SNAKE),
            reader.text(option, "label", where),
        )
        if any(o.id == choice.id for o in options):
            reader.problem(join(where, "id"), f"option id {choice.id!r} used twice")
        options.append(choice)
    if len(options) < 2 and "options" in body:
        reader.problem(path, f"needs at least 2 options, got {len(options)}")
    return tuple(options)
