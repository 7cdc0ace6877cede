"""``procedure.video`` in the study file: participant video is opt-in per study, asked on
the consent page with its own items; it survives the snapshot, and each mistake is refused
at its place and line."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.procedure import DEFAULT_AUDIO_LABEL, DEFAULT_VIDEO_LABEL, Video
from chameleons.experiment.study import StudyError, load_study, study_from_config
from tests.experiment.study_files import default_document, write_study


def located(tmp_path: Path, document: dict[str, Any]) -> list[str]:
    with pytest.raises(StudyError) as caught:
        load_study(write_study(tmp_path, document))
    return caught.value.located


def line(path: Path, text: str) -> int:
    return next(n for n, t in enumerate(path.read_text().splitlines(), 1) if text in t)


def test_video_is_off_unless_the_study_asks(tmp_path: Path) -> None:
    study = load_study(write_study(tmp_path, default_document()))
    assert study.procedure.video is None
    assert not study.procedure.records_video
    assert "video" not in study.config["procedure"]


def test_video_with_its_items_survives_the_snapshot(tmp_path: Path) -> None:
    document = default_document()
    document["procedure"]["video"] = {"record": True, "audio": True,
                                      "label": {"en": "Film me", "sv": "Filma mig"}}  # fmt: skip
    study = load_study(write_study(tmp_path, document))
    assert study.procedure.video == Video(True, True, "Film me", DEFAULT_AUDIO_LABEL)
    assert study.in_language("sv").procedure.video == Video(True, True, "Filma mig",
                                                            DEFAULT_AUDIO_LABEL)  # fmt: skip
    assert study.procedure.records_video
    rebuilt = study_from_config(json.loads(json.dumps(study.config)))
    assert (rebuilt, rebuilt.content_hash) == (study, study.content_hash)
    assert rebuilt.in_language("sv").procedure.video == study.in_language("sv").procedure.video


def test_record_false_keeps_the_section_and_asks_nothing(tmp_path: Path) -> None:
    document = default_document()
    document["procedure"]["video"] = {"record": False}
    study = load_study(write_study(tmp_path, document))
    assert study.procedure.video == Video(False, False, DEFAULT_VIDEO_LABEL, DEFAULT_AUDIO_LABEL)
    assert not study.procedure.records_video


def test_mistakes_are_refused_at_their_line(tmp_path: Path) -> None:
    document = default_document()
    document["procedure"]["video"] = {"record": "yes", "microphone": True}
    problems = located(tmp_path, document)
    path = tmp_path / "study.yaml"
    record = line(path, "record: ")
    assert (
        f"{path}:{record}: procedure.video.record: must be true or false, got text 'yes'"
        in problems
    )
    assert any("procedure.video.microphone: unknown" in p for p in problems)


def test_video_needs_the_consent_page(tmp_path: Path) -> None:
    document = default_document()
    document["procedure"].pop("consent")
    document["procedure"]["video"] = {"record": True}
    problems = located(tmp_path, document)
    path = tmp_path / "study.yaml"
    assert (
        f"{path}:{line(path, '  video:')}: procedure.video: recording video needs the "
        "consent page (procedure.consent), where the participant is asked for it" in problems
    )
