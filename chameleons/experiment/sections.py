"""Reading each section of a study document into model values (problems go to the reader)."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Any, cast

from chameleons.experiment.languages import LANGUAGE
from chameleons.experiment.model import (
    Actor,
    Choice,
    Condition,
    Face,
    FacePairing,
    Item,
    ItemSetRule,
    ItemType,
    NamePairing,
    Personas,
    Phase,
    Questionnaire,
    QuestionnaireItem,
    Task,
    Voice,
)
from chameleons.experiment.reader import SNAKE, Reader, join
from chameleons.worker.behaviours.params import check_params

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
GENDERS = ("female", "male", "other")
MIN_CONDITIONS, MAX_CONDITIONS = 2, 6
NAME_PAIRINGS = ("per_actor", "per_interaction")
FACE_PAIRINGS = ("independent", "per_actor")
RENDERERS = ("2d", "3d")  # the virtual robot display's face a condition may choose
# Declared parameters per behaviour name (see chameleons.worker.behaviours.params); None
# for a behaviour this machine does not have (a stored snapshot keeps its params as stored).
Behaviours = Mapping[str, Mapping[str, Any] | None]


def read_conditions(
    reader: Reader, node: object, behaviours: Behaviours, *, snapshot: bool = False
) -> tuple[Condition, ...]:
    """Conditions with their behaviour and its parameters, checked against what the
    behaviour declares (defaults filled in). A condition without ``behaviour`` runs the
    behaviour of its own name (a study written before conditions named behaviours)."""
    conditions = []
    for cid, body, place in reader.keyed(node, "conditions", SNAKE):
        reader.check_keys(
            body, place, ["label"], ["description", "behaviour", "params", "renderer"]
        )
        behaviour, params = _behaviour(reader, body, cid, place, behaviours, snapshot)
        conditions.append(
            Condition(
                cid,
                reader.text(body, "label", place),
                _optional(reader, body, "description", place),
                behaviour,
                params,
                _renderer(reader, body, place),
            )
        )
    if not MIN_CONDITIONS <= len(conditions) <= MAX_CONDITIONS:
        reader.problem(
            "conditions",
            f"needs {MIN_CONDITIONS} to {MAX_CONDITIONS} conditions, got {len(conditions)}",
        )
    return tuple(conditions)


def _renderer(reader: Reader, body: dict[str, Any], place: str) -> str | None:
    """The virtual robot's face for the condition: 2d, 3d, or None (the booth's own)."""
    value = body.get("renderer")
    if value is None:
        return None
    if value not in RENDERERS:
        reader.problem(
            join(place, "renderer"), f"must be 2d or 3d (the robot display's face), got {value!r}"
        )
        return None
    return str(value)


def _behaviour(
    reader: Reader, body: dict[str, Any], cid: str, place: str, behaviours: Behaviours,
    snapshot: bool,
) -> tuple[str, dict[str, Any]]:  # fmt: skip
    name = body.get("behaviour", cid)
    params_place = join(place, "params")
    given = reader.mapping(body.get("params") or {}, params_place)
    known = ", ".join(sorted(behaviours))
    if not isinstance(name, str) or name not in behaviours:
        if snapshot and isinstance(name, str):  # a plug-in this machine lacks: as stored
            return name, given
        where = join(place, "behaviour")
        if "behaviour" not in body:
            reader.problem(where, f"is missing (a condition runs one of: {known})")
        else:
            reader.problem(where, f"unknown behaviour {name!r} (available: {known})")
        return str(name), given
    declared = behaviours[name]
    if declared is None:
        return name, given
    values, problems = check_params(declared, given)
    for key, message in problems:
        reader.problem(join(params_place, key), message)
    return name, values


def read_tasks(reader: Reader, node: object) -> tuple[Task, ...]:
    tasks = []
    for tid, body, place in reader.keyed(node, "tasks", SNAKE):
        reader.check_keys(body, place, ["name", "items"], ["source", "introduction"])
        items = _read_items(reader, body.get("items", []), join(place, "items"))
        tasks.append(
            Task(
                id=tid,
                name=reader.text(body, "name", place),
                source=_optional(reader, body, "source", place),
                introduction=_optional(reader, body, "introduction", place),
                items=items,
            )
        )
    if not tasks:
        reader.problem("tasks", "needs at least one task")
    return tuple(tasks)


def _read_items(reader: Reader, node: object, path: str) -> tuple[Item, ...]:
    items = []
    for index, element in enumerate(reader.sequence(node, path)):
        place = join(path, index)
        body = reader.mapping(element, place)
        reader.check_keys(body, place, ["id", "name", "expert_rank"], ["description"])
        items.append(
            Item(
                id=reader.identifier(body.get("id"), join(place, "id"), SNAKE),
                name=reader.text(body, "name", place),
                description=_optional(reader, body, "description", place),
                expert_rank=reader.integer(body, "expert_rank", place, minimum=1),
            )
        )
    _check_unique_items(reader, items, path)
    return tuple(items)


def _check_unique_items(reader: Reader, items: list[Item], path: str) -> None:
    first_index: dict[str, int] = {}
    rank_index: dict[int, int] = {}
    for index, item in enumerate(items):
        if item.id in first_index:
            reader.problem(join(path, index), f"item id {item.id!r} used twice")
        first_index.setdefault(item.id, index)
        if item.expert_rank in rank_index:
            reader.problem(join(path, index), f"expert rank {item.expert_rank} used twice")
        rank_index.setdefault(item.expert_rank, index)
    missing = sorted(set(range(1, len(items) + 1)) - set(rank_index))
    if items and missing:
        reader.problem(path, f"expert ranks must be 1..{len(items)}; missing {missing}")


def read_item_sets(reader: Reader, node: object, tasks: tuple[Task, ...]) -> ItemSetRule:
    path = "item_sets"
    body = reader.mapping(node, path)
    reader.check_keys(body, path, ["first_rank", "last_rank", "sets"], [])
    first = reader.integer(body, "first_rank", path, minimum=1)
    last = reader.integer(body, "last_rank", path, minimum=1)
    sets = [
        reader.identifier(s, join(join(path, "sets"), i), SNAKE)
        for i, s in enumerate(reader.sequence(body.get("sets", []), join(path, "sets")))
    ]
    for set_id, count in Counter(sets).items():
        if count > 1:
            reader.problem(join(path, "sets"), f"set {set_id!r} named twice")
    span = last - first + 1
    if span < 1:
        reader.problem(path, f"last_rank {last} is before first_rank {first}")
    elif not sets:
        reader.problem(join(path, "sets"), "needs at least one set")
    elif span % len(sets):
        reader.problem(path, f"ranks {first}..{last} ({span}) do not split into {len(sets)} sets")
    for task in tasks:
        if task.items and last > len(task.items):
            reader.problem(
                join("tasks", task.id),
                f"has {len(task.items)} items but item_sets uses rank {last}",
            )
    return ItemSetRule(first, last, tuple(sets))


def read_actors(reader: Reader, node: object) -> tuple[Actor, ...]:
    actors = []
    for aid, body, place in reader.keyed(node, "actors"):
        reader.check_keys(body, place, ["name", "gender", "voice"], ["properties"])
        voice_place = join(place, "voice")
        voice = reader.mapping(body.get("voice", {}), voice_place)
        if "voice" in body:  # a missing voice is one problem, not one per field
            reader.check_keys(voice, voice_place, ["espeak"], ["pitch", "speed", "furhat"])
        actors.append(
            Actor(
                id=aid,
                name=reader.text(body, "name", place),
                gender=reader.text(body, "gender", place),
                voice=Voice(
                    espeak=reader.text(voice, "espeak", voice_place),
                    pitch=reader.integer(
                        voice, "pitch", voice_place, default=50, minimum=0, maximum=99
                    ),
                    speed=reader.integer(
                        voice, "speed", voice_place, default=160, minimum=80, maximum=450
                    ),
                    furhat=_furhat_voice(reader, voice.get("furhat"), join(voice_place, "furhat")),
                ),
                properties=_properties(reader, body, place),
            )
        )
    return tuple(actors)


def _furhat_voice(reader: Reader, node: object, path: str) -> dict[str, str]:
    """A Furhat voice name for every language (key ``""``), or one per language code."""
    if node is None:
        return {}
    if isinstance(node, str):
        if not node.strip():
            reader.problem(path, "must name a Furhat voice, or one per language ({en: ...})")
        return {"": node.strip()} if node.strip() else {}
    voices = reader.mapping(node, path)
    for language, name in voices.items():
        if not LANGUAGE.match(language) or not (isinstance(name, str) and name.strip()):
            reader.problem(join(path, language), "must be a language code with a voice name")
    return {language: str(name).strip() for language, name in voices.items()}


def read_faces(reader: Reader, node: object) -> tuple[Face, ...]:
    faces = []
    for fid, body, place in reader.keyed(node, "faces"):
        reader.check_keys(body, place, ["label"], ["gender", "age", "properties"])
        faces.append(
            Face(
                fid,
                reader.text(body, "label", place),
                _gender(reader, body, place),
                _optional(reader, body, "age", place),
                _properties(reader, body, place),
            )
        )
    return tuple(faces)


def _gender(reader: Reader, body: dict[str, Any], place: str) -> str:
    gender = _optional(reader, body, "gender", place)
    if gender and gender not in GENDERS:
        reader.problem(join(place, "gender"), f"must be one of {list(GENDERS)}, got {gender!r}")
    return gender


def read_robot_names(reader: Reader, node: object) -> tuple[tuple[str, ...], dict[str, str]]:
    """The names, and the gender of those given one (``{name: Iris, gender: female}``)."""
    names: list[str] = []
    genders: dict[str, str] = {}
    for index, entry in enumerate(reader.sequence(node, "robot_names")):
        place = join("robot_names", index)
        name, gender = entry, ""
        if isinstance(entry, Mapping):
            body = reader.mapping(entry, place)
            reader.check_keys(body, place, ["name"], ["gender"])
            name, gender = body.get("name"), _gender(reader, body, place)
        if not isinstance(name, str) or not name.strip():
            reader.problem(place, "must be a non-empty name")
        elif name.strip() in names:
            reader.problem(place, f"name {name!r} listed twice")
        else:
            names.append(name.strip())
            if gender:
                genders[name.strip()] = gender
    return tuple(names), genders


# A snapshot stored before personas were a setting: names were drawn per session, faces
# counterbalanced on their own, genders not matched.
LEGACY_PERSONAS = Personas("per_interaction", "independent", False)


def read_personas(reader: Reader, node: object, *, snapshot: bool = False) -> Personas:
    path = "personas"
    if snapshot and node is None:
        return LEGACY_PERSONAS
    body = reader.mapping({} if node is None else node, path)
    reader.check_keys(body, path, [], ["names", "faces", "match_gender"])
    names = body.get("names", "per_actor")
    if names not in NAME_PAIRINGS:
        reader.problem(join(path, "names"), f"must be one of {list(NAME_PAIRINGS)}, got {names!r}")
    faces = body.get("faces", "independent")
    if faces not in FACE_PAIRINGS:
        reader.problem(join(path, "faces"), f"must be one of {list(FACE_PAIRINGS)}, got {faces!r}")
    return Personas(
        names=cast(NamePairing, names if names in NAME_PAIRINGS else "per_actor"),
        faces=cast(FacePairing, faces if faces in FACE_PAIRINGS else "independent"),
        match_gender=reader.boolean(body, "match_gender", path, default=False),
    )


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
                low=_optional(reader, scale, "low", scale_place),
                high=_optional(reader, scale, "high", scale_place),
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
            text=_optional(reader, body, "text", place),
            left=_optional(reader, body, "left", place),
            right=_optional(reader, body, "right", place),
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


def _optional(reader: Reader, body: dict[str, Any], key: str, place: str) -> str:
    return reader.text(body, key, place, default="", allow_empty=True)


def _properties(reader: Reader, body: dict[str, Any], place: str) -> dict[str, Any]:
    return (
        reader.mapping(body["properties"], join(place, "properties"))
        if "properties" in body
        else {}
    )
