"""The study as typed, immutable values (built by :mod:`chameleons.experiment.study`).

Collections are tuples in the order the study file gives them; lookups by id are methods.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any, Literal

from chameleons.experiment.procedure import Procedure

ItemType = Literal["differential", "agreement", "text", "choice", "robot"]
Phase = Literal["before", "interaction", "final"]
SuggestionRule = Literal["expert_place", "best_move", "up_only"]
NamePairing = Literal["per_actor", "per_interaction"]
FacePairing = Literal["independent", "per_actor"]


@dataclass(frozen=True)
class Item:
    """One survival-task item; ``expert_rank`` 1 is the most important."""

    id: str
    name: str
    description: str
    expert_rank: int


@dataclass(frozen=True)
class Task:
    id: str
    name: str
    source: str
    introduction: str
    items: tuple[Item, ...]

    def item(self, item_id: str) -> Item:
        for item in self.items:
            if item.id == item_id:
                return item
        raise KeyError(f"task {self.id!r} has no item {item_id!r}")

    @property
    def expert_order(self) -> tuple[str, ...]:
        """All item ids, most important first."""
        return tuple(item.id for item in sorted(self.items, key=lambda i: i.expert_rank))


@dataclass(frozen=True)
class ItemSetRule:
    """Expert ranks ``first_rank..last_rank`` split, in expert order, into equal sets."""

    first_rank: int
    last_rank: int
    sets: tuple[str, ...]

    @property
    def set_size(self) -> int:
        return (self.last_rank - self.first_rank + 1) // len(self.sets)

    def ranks_of(self, set_id: str) -> range:
        start = self.first_rank + self.sets.index(set_id) * self.set_size
        return range(start, start + self.set_size)


@dataclass(frozen=True)
class Scenario:
    """A task with one item set: the five items of one interaction, in expert order."""

    task: str
    item_set: str
    items: tuple[str, ...]

    @property
    def id(self) -> str:
        return f"{self.task}-{self.item_set}"


@dataclass(frozen=True)
class Condition:
    """A condition runs ``behaviour`` (a registered behaviour of the worker) with ``params``
    (checked against the behaviour's declared parameters, defaults filled in). ``renderer``
    ("2d" or "3d") sets the virtual robot display's face for the condition, "furhat" runs it
    on the booth's Furhat (so embodiment can be a counterbalanced factor; a booth with both
    robots runs its worker with ``--driver virtual+furhat``); None leaves the booth's own
    choice."""

    id: str
    label: str
    description: str
    behaviour: str
    params: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)
    renderer: str | None = None


@dataclass(frozen=True)
class Voice:
    """A hint for synthetic demo voices (espeak-ng voice name, pitch 0-99, words/min), and
    the Furhat's own TTS voice for typed speech on a Furhat: ``furhat`` maps a language to
    a voice name (key ``""``: every language); empty keeps the robot's current voice."""

    espeak: str
    pitch: int
    speed: int
    furhat: dict[str, str] = field(default_factory=dict, hash=False)

    def furhat_voice(self, language: str | None) -> str | None:
        """The Furhat voice for a session in ``language`` (None: the robot's own)."""
        return self.furhat.get(language or "") or self.furhat.get("") or None


@dataclass(frozen=True)
class Actor:
    id: str
    name: str
    gender: str
    voice: Voice
    properties: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)


@dataclass(frozen=True)
class Face:
    """A robot face; ``gender`` (when given) is what the face looks like, for the optional
    face/voice gender match; ``age`` describes it for the methods section."""

    id: str
    label: str
    gender: str = ""
    age: str = ""
    properties: dict[str, Any] = field(default_factory=dict, hash=False, compare=False)


@dataclass(frozen=True)
class Personas:
    """How voices (actors), robot names and faces combine into the robot personalities.

    ``names``: ``per_actor`` gives every actor one name for the whole study (drawn once
    with the plan seed; the paper: "each actor was given a randomized name"),
    ``per_interaction`` draws names afresh for every session. ``faces``: ``independent``
    counterbalances faces on their own (the paper), ``per_actor`` ties one face to each
    actor for the whole study. ``match_gender``: a face (and a name) with a gender is only
    combined with a voice of the same gender."""

    names: NamePairing = "per_actor"
    faces: FacePairing = "independent"
    match_gender: bool = False


@dataclass(frozen=True)
class Choice:
    """One answer of a ``choice`` item: ``id`` is what the data record, ``label`` what the
    participant reads."""

    id: str
    label: str


@dataclass(frozen=True)
class QuestionnaireItem:
    """A question. ``differential``: anchors ``left`` (1) and ``right`` (max);
    ``agreement``: a statement rated on the scale; ``text``: an open answer; ``choice``: one
    of ``options``; ``robot``: one of the robots the participant met (or "don't know"), which
    the export resolves to that robot's condition (a manipulation check).
    ``required``: the phone refuses the page until it is answered (the loader's default:
    rated items required, open questions optional, as ethics boards expect); a skipped
    item is stored as skipped, never as a default value."""

    id: str
    type: ItemType
    text: str = ""
    left: str = ""
    right: str = ""
    reverse: bool = False
    identifying: bool = False
    required: bool = True
    options: tuple[Choice, ...] = ()

    @property
    def numeric(self) -> bool:
        """Rated on the questionnaire's scale (and so scored)."""
        return self.type in ("differential", "agreement")


@dataclass(frozen=True)
class Questionnaire:
    id: str
    version: str
    title: str
    phase: Phase
    points: int
    low: str
    high: str
    items: tuple[QuestionnaireItem, ...]

    @property
    def numeric_items(self) -> tuple[QuestionnaireItem, ...]:
        return tuple(item for item in self.items if item.numeric)

    @property
    def scored(self) -> bool:
        """Whether answers average into one score (it has numeric items)."""
        return bool(self.numeric_items)


@dataclass(frozen=True)
class Study:
    """A validated study. ``config`` is its canonical JSON-able snapshot, ``content_hash``
    the sha256 of that snapshot's canonical JSON (see :func:`study.canonical_json`)."""

    id: str
    name: str
    description: str
    conditions: tuple[Condition, ...]
    tasks: tuple[Task, ...]
    item_sets: ItemSetRule
    suggestions_per_interaction: int
    suggestion_rule: SuggestionRule
    alternate_tasks: bool
    actors: tuple[Actor, ...]
    faces: tuple[Face, ...]
    robot_names: tuple[str, ...]
    personas: Personas
    questionnaires: tuple[Questionnaire, ...]
    config: dict[str, Any] = field(hash=False, compare=False, repr=False)
    content_hash: str = field(compare=True)
    # robot name -> gender, for names the study gives one (match_gender keeps them apart)
    name_genders: dict[str, str] = field(default_factory=dict, hash=False, compare=False)
    warnings: tuple[str, ...] = field(default=(), hash=False, compare=False)
    # consent and debriefing pages (none for a study that does not declare them)
    procedure: Procedure = field(default_factory=Procedure, hash=False, compare=True)
    # The participants' languages (texts of this object: the default language's) and the
    # same study with each other language's texts (chameleons.experiment.languages).
    languages: tuple[str, ...] = ("en",)
    default_language: str = "en"
    localized: dict[str, Study] = field(default_factory=dict, hash=False, compare=False, repr=False)

    def in_language(self, language: str) -> Study:
        """The study with the texts a participant of ``language`` sees (the default
        language's for a language the study does not declare)."""
        return self.localized.get(language, self)

    @property
    def condition_ids(self) -> tuple[str, ...]:
        return tuple(c.id for c in self.conditions)

    @property
    def interactions_per_session(self) -> int:
        """One interaction per condition (within-subjects)."""
        return len(self.conditions)

    def task(self, task_id: str) -> Task:
        for task in self.tasks:
            if task.id == task_id:
                return task
        raise KeyError(f"no task {task_id!r}")

    def condition(self, condition_id: str) -> Condition:
        for condition in self.conditions:
            if condition.id == condition_id:
                return condition
        raise KeyError(f"no condition {condition_id!r}")

    def actor(self, actor_id: str) -> Actor:
        for actor in self.actors:
            if actor.id == actor_id:
                return actor
        raise KeyError(f"no actor {actor_id!r}")

    def face(self, face_id: str) -> Face:
        for face in self.faces:
            if face.id == face_id:
                return face
        raise KeyError(f"no face {face_id!r}")

    def questionnaire(self, questionnaire_id: str) -> Questionnaire:
        for questionnaire in self.questionnaires:
            if questionnaire.id == questionnaire_id:
                return questionnaire
        raise KeyError(f"no questionnaire {questionnaire_id!r}")

    def questionnaires_for(self, phase: Phase) -> tuple[Questionnaire, ...]:
        return tuple(q for q in self.questionnaires if q.phase == phase)

    @property
    def measures(self) -> tuple[str, ...]:
        """Analysed measures: accepted suggestions, then each scored interaction questionnaire."""
        scored = (q.id for q in self.questionnaires_for("interaction") if q.scored)
        return ("accepted", *scored)

    def scenario(self, task_id: str, item_set: str) -> Scenario:
        task = self.task(task_id)
        ranks = self.item_sets.ranks_of(item_set)
        chosen = sorted((i for i in task.items if i.expert_rank in ranks), key=_rank)
        return Scenario(task_id, item_set, tuple(i.id for i in chosen))

    @property
    def scenarios(self) -> tuple[Scenario, ...]:
        """Every task x item set, tasks in study order, sets in rule order."""
        return tuple(
            self.scenario(task.id, set_id) for task in self.tasks for set_id in self.item_sets.sets
        )

    def expert_order(self, task_id: str, item_ids: tuple[str, ...] | list[str]) -> list[str]:
        """The given items of a task, most important first (the policy's target order)."""
        task = self.task(task_id)
        return sorted(item_ids, key=lambda item_id: task.item(item_id).expert_rank)


def _rank(item: Item) -> int:
    return item.expert_rank
