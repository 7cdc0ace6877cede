"""Reading each section of a study document into model values (problems go to the reader).

The questionnaires' sections are read in :mod:`.questionnaire_sections`."""

from __future__ import annotations

from collections import Counter
from collections.abc import Mapping
from typing import Any, cast

from chameleons.experiment.languages import LANGUAGE
from chameleons.experiment.model import (
    Actor,
    Condition,
    Face,
    FacePairing,
    Item,
    ItemSetRule,
    NamePairing,
    Personas,
    Task,
    Voice,
)
from chameleons.experiment.questionnaire_sections import ITEM_KEYS as ITEM_KEYS
from chameleons.experiment.questionnaire_sections import ITEM_TYPES as ITEM_TYPES
from chameleons.experiment.questionnaire_sections import PHASES as PHASES
from chameleons.experiment.questionnaire_sections import (
    read_questionnaires as read_questionnaires,
)
from chameleons.experiment.reader import SNAKE, Reader, join, optional_text
from chameleons.worker.behaviours.params import check_params

GENDERS = ("female", "male", "other")
MIN_CONDITIONS, MAX_CONDITIONS = 2, 6
NAME_PAIRINGS = ("per_actor", "per_interaction")
FACE_PAIRINGS = ("independent", "per_actor")
# The robot face a condition may choose: the virtual display's 2d or 3d face, or the booth's
# Furhat (its worker drives both robots with --driver virtual+furhat, or a Furhat only).
RENDERERS = ("2d", "3d", "furhat")
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
                optional_text(reader, body, "description", place),
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
    """The robot's face for the condition: 2d, 3d (the display), furhat, or None (the
    booth's own)."""
    value = body.get("renderer")
    if value is None:
        return None
    if value not in RENDERERS:
        reader.problem(
            join(place, "renderer"),
            f"must be 2d or 3d (the robot display's face) or furhat, got {value!r}",
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
                source=optional_text(reader, body, "source", place),
                introduction=optional_text(reader, body, "introduction", place),
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
                description=optional_text(reader, body, "description", place),
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
                optional_text(reader, body, "age", place),
                _properties(reader, body, place),
            )
        )
    return tuple(faces)


def _gender(reader: Reader, body: dict[str, Any], place: str) -> str:
    gender = optional_text(reader, body, "gender", place)
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


def _properties(reader: Reader, body: dict[str, Any], place: str) -> dict[str, Any]:
    return (
        reader.mapping(body["properties"], join(place, "properties"))
        if "properties" in body
        else {}
    )
