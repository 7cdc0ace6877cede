"""The steps before and after the interactions, as study data: the consent page and the
debriefing page (the demographics questionnaire is a questionnaire with ``phase: before``,
the manipulation check items of the final questionnaire).

``procedure`` in the study file is optional; a study without it (or a snapshot stored
before it existed) has no consent step and no debriefing, as the software had then.
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

from chameleons.experiment.reader import Reader, join
from chameleons.i18n import N_

# The phone shows these defaults in the participant's language (chameleons/locale).
DEFAULT_AGREE = N_("I agree to take part")
DEFAULT_DECLINE = N_("I do not want to take part")
DEFAULT_CONSENT_TITLE = N_("Consent to take part")
DEFAULT_DEBRIEFING_TITLE = N_("About this study")
DEFAULT_VIDEO_LABEL = N_("I agree to be filmed during the session (the video stays with the lab)")
DEFAULT_AUDIO_LABEL = N_("I agree to my voice being recorded with the video")


@dataclass(frozen=True)
class Consent:
    """The consent page the phone shows first. ``version`` is recorded with the answer;
    ``text`` is split into paragraphs at blank lines."""

    version: str
    title: str
    text: str
    agree: str = DEFAULT_AGREE
    decline: str = DEFAULT_DECLINE


@dataclass(frozen=True)
class Debriefing:
    """The page after the last answer (and after an ended session that had started): what
    the study was about, including what the participant was not told before."""

    title: str
    text: str


@dataclass(frozen=True)
class Video:
    """Participant video (opt-in per study): the booth's camera is recorded only for a
    participant who ticked ``label`` on the consent page, their microphone only when
    ``audio`` and they ticked ``audio_label`` too. ``record: false`` keeps the section but
    records nothing (and asks nothing)."""

    record: bool
    audio: bool = False
    label: str = DEFAULT_VIDEO_LABEL
    audio_label: str = DEFAULT_AUDIO_LABEL


@dataclass(frozen=True)
class Procedure:
    consent: Consent | None = None
    debriefing: Debriefing | None = None
    video: Video | None = None

    @property
    def records_video(self) -> bool:
        """Whether the consent page asks for video (the study opted in and has one)."""
        return self.video is not None and self.video.record and self.consent is not None


def paragraphs(text: str) -> list[str]:
    return [" ".join(part.split()) for part in text.split("\n\n") if part.strip()]


def read_procedure(reader: Reader, node: object) -> Procedure:
    if node is None:
        return Procedure()
    body = reader.mapping(node, "procedure")
    reader.check_keys(body, "procedure", [], ["consent", "debriefing", "video"])
    consent = None
    if "consent" in body:
        place = join("procedure", "consent")
        part = reader.mapping(body["consent"], place)
        reader.check_keys(part, place, ["version", "text"], ["title", "agree", "decline"])
        consent = Consent(
            version=reader.text(part, "version", place),
            title=reader.text(part, "title", place, default=DEFAULT_CONSENT_TITLE),
            text=_long_text(reader, part, place),
            agree=reader.text(part, "agree", place, default=DEFAULT_AGREE),
            decline=reader.text(part, "decline", place, default=DEFAULT_DECLINE),
        )
    debriefing = None
    if "debriefing" in body:
        place = join("procedure", "debriefing")
        part = reader.mapping(body["debriefing"], place)
        reader.check_keys(part, place, ["text"], ["title"])
        debriefing = Debriefing(
            title=reader.text(part, "title", place, default=DEFAULT_DEBRIEFING_TITLE),
            text=_long_text(reader, part, place),
        )
    video = _read_video(reader, body) if "video" in body else None
    if video is not None and video.record and consent is None:
        reader.problem(join("procedure", "video"), "recording video needs the consent page "
                       "(procedure.consent), where the participant is asked for it")  # fmt: skip
    return Procedure(consent, debriefing, video)


def _read_video(reader: Reader, body: dict[str, Any]) -> Video:
    place = join("procedure", "video")
    part = reader.mapping(body["video"], place)
    reader.check_keys(part, place, ["record"], ["audio", "label", "audio_label"])
    return Video(
        record=reader.boolean(part, "record", place, default=False),
        audio=reader.boolean(part, "audio", place, default=False),
        label=reader.text(part, "label", place, default=DEFAULT_VIDEO_LABEL),
        audio_label=reader.text(part, "audio_label", place, default=DEFAULT_AUDIO_LABEL),
    )


def _long_text(reader: Reader, part: dict[str, Any], place: str) -> str:
    """Paragraphs kept (YAML ``|`` blocks); each paragraph's line breaks are spaces."""
    text = reader.text(part, "text", place)
    return "\n\n".join(paragraphs(text))


def procedure_config(procedure: Procedure) -> dict[str, Any] | None:
    """The snapshot's ``procedure`` (None when the study has neither step, so a study
    without one keeps the hash it had before the setting existed)."""
    data: dict[str, Any] = {}
    if procedure.consent is not None:
        data["consent"] = dict(procedure.consent.__dict__)
    if procedure.debriefing is not None:
        data["debriefing"] = dict(procedure.debriefing.__dict__)
    if procedure.video is not None:
        data["video"] = dict(procedure.video.__dict__)
    return data or None
