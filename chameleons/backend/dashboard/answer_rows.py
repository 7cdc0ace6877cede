"""A session's questionnaire answers as the PI reads them on the session page: each page by
its title, each question by its text, each answer in words (a choice by its label, a robot
by the interaction and name the participant met it under, a skipped item as skipped), not
the ids the database keeps (the export has those, with the codebook)."""

from __future__ import annotations

from collections.abc import Iterable, Mapping
from dataclasses import dataclass, field

from chameleons.backend.export.scoring import questionnaire_score
from chameleons.backend.models import QuestionnaireResponse
from chameleons.backend.sessions.answers import DONT_KNOW
from chameleons.experiment.model import Questionnaire, QuestionnaireItem
from chameleons.experiment.model import Study as StudySpec


@dataclass(frozen=True)
class AnswerRow:
    question: str
    answer: str
    skipped: bool = False


@dataclass
class AnsweredPage:
    """One questionnaire of the session as answered: ``score`` for a scored one."""

    id: str
    title: str
    score: float | None = None
    scored: bool = False
    rows: list[AnswerRow] = field(default_factory=list)


def answered_pages(
    spec: StudySpec, answers: Iterable[QuestionnaireResponse], robots: Mapping[int, str]
) -> list[AnsweredPage]:
    """The questionnaires among ``answers``, in the order answered; ``robots``: the robot's
    name in each interaction (position -> name), for the manipulation check's answer."""
    pages: dict[str, AnsweredPage] = {}
    values: dict[str, dict[str, int]] = {}
    for answer in answers:
        questionnaire = _questionnaire(spec, answer.questionnaire)
        page = pages.get(answer.questionnaire)
        if page is None:
            title = questionnaire.title if questionnaire else answer.questionnaire
            scored = bool(questionnaire and questionnaire.scored)
            page = pages[answer.questionnaire] = AnsweredPage(answer.questionnaire, title,
                                                              scored=scored)  # fmt: skip
        item = _item(questionnaire, answer.item)
        page.rows.append(_row(item, answer, robots, answer.item))
        if answer.value is not None:
            values.setdefault(answer.questionnaire, {})[answer.item] = answer.value
    for page in pages.values():
        questionnaire = _questionnaire(spec, page.id)
        if questionnaire is not None and page.scored:
            page.score = questionnaire_score(questionnaire, values.get(page.id, {}))
    return list(pages.values())


def _questionnaire(spec: StudySpec, questionnaire_id: str) -> Questionnaire | None:
    try:
        return spec.questionnaire(questionnaire_id)
    except KeyError:  # a questionnaire the study no longer has: its id, then
        return None


def _item(questionnaire: Questionnaire | None, item_id: str) -> QuestionnaireItem | None:
    if questionnaire is None:
        return None
    return next((item for item in questionnaire.items if item.id == item_id), None)


def _row(
    item: QuestionnaireItem | None,
    answer: QuestionnaireResponse,
    robots: Mapping[int, str],
    item_id: str,
) -> AnswerRow:
    question = _question(item) or item_id
    if answer.skipped or (answer.value is None and answer.text is None):
        return AnswerRow(question, "skipped", skipped=True)
    if item is not None and item.type == "robot":
        return AnswerRow(question, _robot(answer, robots))
    if item is not None and item.type == "choice":
        label = next((o.label for o in item.options if o.id == answer.text), None)
        return AnswerRow(question, label or str(answer.text))
    return AnswerRow(question, str(answer.text if answer.text is not None else answer.value))


def _question(item: QuestionnaireItem | None) -> str:
    if item is None:
        return ""
    if item.type == "differential":
        return f"{item.left} \u2013 {item.right}"  # an en dash, as the phone shows it
    return item.text


def _robot(answer: QuestionnaireResponse, robots: Mapping[int, str]) -> str:
    if answer.text == DONT_KNOW:
        return "don't know"
    if answer.value is None:
        return str(answer.text)
    name = robots.get(answer.value)
    return f"the robot of interaction {answer.value}{f' ({name})' if name else ''}"
