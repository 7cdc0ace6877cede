"""Study texts per language: the default study in English and Swedish, missing or
undeclared translations refused with file:line, and the hash covering every translation."""

from __future__ import annotations

import shutil
from pathlib import Path
from typing import Any

import pytest

from chameleons.experiment.model import Study
from chameleons.experiment.study import (
    StudyError,
    default_study_path,
    load_default_study,
    load_study,
    study_from_config,
)
from tests.experiment.study_files import default_document, with_german, write_study
from tests.support.catalogues import MakeCatalogues, filler


def participant_texts(study: Study) -> list[str]:
    """Every text of the study a participant reads."""
    texts: list[str] = []
    for task in study.tasks:
        texts += [task.name, task.introduction, *(item.name for item in task.items)]
    for q in study.questionnaires:
        texts += [q.title, q.low, q.high]
        for item in q.items:
            texts += [item.text, item.left, item.right, *(o.label for o in item.options)]
    consent, debriefing = study.procedure.consent, study.procedure.debriefing
    assert consent is not None
    assert debriefing is not None
    texts += [consent.title, consent.text, consent.agree, consent.decline]
    return [*texts, debriefing.title, debriefing.text]


def line_of(path: Path, marker: str) -> int:
    lines = path.read_text("utf-8").splitlines()
    return next(n for n, text in enumerate(lines, 1) if marker in text)


def test_the_default_study_is_in_english_and_swedish() -> None:
    study = load_default_study()
    assert study.languages == ("en", "sv")
    assert study.default_language == "en"
    swedish = study.in_language("sv")
    assert swedish.task("lunar").name == "Vilse på månen"
    assert swedish.task("desert").item("vodka").name == "Två liter 90-procentig vodka"
    assert swedish.questionnaire("likeability").high == "Instämmer helt"
    assert swedish.procedure.consent is not None
    assert swedish.procedure.consent.agree == "Jag samtycker till att delta"
    assert study.task("lunar").name == "Lost on the Moon"
    # Unknown languages get the default's texts; ids, versions and design are shared.
    assert study.in_language("de") is study
    assert swedish.content_hash == study.content_hash
    assert [q.version for q in swedish.questionnaires] == [q.version for q in study.questionnaires]
    assert swedish.task("lunar").expert_order == study.task("lunar").expert_order
    # Every text the participant reads differs from the English one except a few that
    # are the same word in both languages (Intelligent, Man, 18-24, ...).
    english, translated = participant_texts(study), participant_texts(swedish)
    same = [e for e, s in zip(english, translated, strict=True) if e == s and e]
    assert set(same) <= {"Intelligent", "Man", "18-24", "25-34", "35-44", "45-54", "55-64"}


def test_a_snapshot_rebuilds_every_language_with_the_same_hash() -> None:
    study = load_default_study()
    rebuilt = study_from_config(study.config)
    assert rebuilt.content_hash == study.content_hash
    assert rebuilt.in_language("sv") == study.in_language("sv")
    assert rebuilt.in_language("sv").procedure == study.in_language("sv").procedure
    assert study.config["languages"] == ["en", "sv"]
    item = study.config["tasks"][0]["items"][0]
    assert item["name"] == {"en": "Two 100-lb tanks of oxygen", "sv": "Två syrgastuber på 45 kg"}


def test_the_hash_covers_the_translations(tmp_path: Path) -> None:
    document = default_document()
    document["tasks"]["lunar"]["items"][0]["name"]["sv"] = "Två tuber syrgas"
    changed = load_study(write_study(tmp_path, document))
    assert changed.content_hash != load_default_study().content_hash
    assert changed.in_language("sv").task("lunar").item("oxygen").name == "Två tuber syrgas"


def test_a_missing_translation_is_refused_with_file_and_line(tmp_path: Path) -> None:
    document = default_document()
    del document["tasks"]["lunar"]["items"][2]["name"]["sv"]
    del document["procedure"]["debriefing"]["text"]["sv"]
    path = write_study(tmp_path, document)
    with pytest.raises(StudyError) as caught:
        load_study(path)
    name_line = line_of(path, "en: Stellar map") - 1
    text_line = next(
        n
        for n, text in enumerate(path.read_text("utf-8").splitlines(), 1)
        if text.strip() == "text:" and n > line_of(path, "debriefing:")
    )
    languages = "(the study's languages: ['en', 'sv'])"
    assert caught.value.located == [
        f"{path}:{name_line}: tasks.lunar.items[2].name: has no sv text {languages}",
        f"{path}:{text_line}: procedure.debriefing.text: has no sv text {languages}",
    ]


@pytest.mark.parametrize(
    ("change", "expected"),
    [
        (
            lambda d: d["questionnaires"]["trust"].update(title={"en": "Trust", "de": "V"}),
            [
                "questionnaires.trust.title: has no sv text (the study's languages: ['en', 'sv'])",
                "questionnaires.trust.title.de: is a language the study does not declare "
                "(languages: ['en', 'sv'])",
            ],
        ),
        (
            lambda d: d["questionnaires"]["trust"].update(title={"en": "Trust", "sv": " "}),
            ["questionnaires.trust.title.sv: must be a non-empty text"],
        ),
        (
            lambda d: d.update(languages=["en", "sv", "sv"]),
            ["languages[2]: 'sv' listed twice"],
        ),
        (
            lambda d: d.update(default_language="fi"),
            ["default_language: 'fi' is not one of languages ['en', 'sv']"],
        ),
        (
            lambda d: d.update(languages=["english"]),
            ["languages[0]: 'english' is not a language code (en, sv)"],
        ),
    ],
)
def test_bad_language_declarations_are_refused(
    tmp_path: Path, change: Any, expected: list[str]
) -> None:
    document = default_document()
    change(document)
    with pytest.raises(StudyError) as caught:
        load_study(write_study(tmp_path, document))
    if expected[0].startswith("languages[0]"):  # every sv text is then undeclared too
        assert caught.value.problems[0] == expected[0]
    else:
        assert caught.value.problems == expected


def test_a_plain_string_is_the_same_in_every_language_and_the_default_may_be_swedish(
    tmp_path: Path,
) -> None:
    document = default_document()
    document["tasks"]["lunar"]["name"] = "Apollo"
    document["default_language"] = "sv"
    study = load_study(write_study(tmp_path, document))
    assert study.default_language == "sv"
    assert study.task("lunar").name == "Apollo"
    assert study.task("desert").name == "Överlevnad i öknen"
    assert study.in_language("en").task("desert").name == "Desert survival"
    assert study_from_config(study.config).content_hash == study.content_hash


def test_a_study_without_languages_keeps_its_snapshot_and_hash() -> None:
    path = default_study_path().parent.parent / "copy_delay" / "study.yaml"
    copy_study = load_study(path)
    assert copy_study.languages == ("en",)
    assert "languages" not in copy_study.config
    assert copy_study.in_language("sv") is copy_study


def catalogue_warnings(study: Study) -> list[str]:
    return [w for w in study.warnings if "the phone's own texts" in w]


def german_line(path: Path) -> int:
    """The line of ``- de`` in the study's block list of languages."""
    lines = path.read_text("utf-8").splitlines()
    start = lines.index("languages:")
    return start + 1 + lines[start:].index("- de")


def test_a_language_without_the_phones_catalogue_is_refused_saying_how_to_add_one(
    tmp_path: Path,
) -> None:
    path = write_study(tmp_path, with_german(default_document()))
    with pytest.raises(StudyError) as caught:
        load_study(path)
    [problem] = caught.value.located
    assert problem.startswith(f"{path}:{german_line(path)}: languages[2]: 'de' has no ")
    assert "phone's own texts" in problem
    assert "`make i18n-extract`" in problem
    assert "chameleons/locale/de/LC_MESSAGES/messages.po and phone.po" in problem


def test_english_of_any_region_needs_no_catalogue(tmp_path: Path) -> None:
    document = default_document()
    document["languages"] = ["en-GB", "sv"]
    text = write_study(tmp_path, document).read_text("utf-8").replace("en: ", "en-GB: ")
    (tmp_path / "study.yaml").write_text(text, "utf-8")
    study = load_study(tmp_path / "study.yaml")
    assert study.languages == ("en-GB", "sv")
    assert catalogue_warnings(study) == []


def test_with_its_catalogue_a_language_loads_and_untranslated_phone_texts_are_warned(
    tmp_path: Path, extra_catalogues: MakeCatalogues
) -> None:
    german = filler("Deutsch")
    extra_catalogues({"de": german})
    path = write_study(tmp_path, with_german(default_document()))
    study = load_study(path)
    assert study.languages == ("en", "sv", "de")
    assert catalogue_warnings(study) == []
    assert study.in_language("de").task("lunar").name == "Lost on the Moon (de)"

    # Two of the phone's texts left untranslated: loaded, with a warning at the language.
    extra_catalogues({"de": lambda m: "" if m in ("Connected", "(optional)") else german(m)})
    study = load_study(path)
    assert catalogue_warnings(study) == [
        f"{path}:{german_line(path)}: languages[2]: 2 of the phone's own texts have "
        "no de translation in chameleons/locale/de/LC_MESSAGES/ (the phone shows them in "
        "English; `make test` fails until they are translated)"
    ]


def test_a_stored_study_whose_language_lost_its_catalogue_still_loads_with_a_warning(
    tmp_path: Path, extra_catalogues: MakeCatalogues
) -> None:
    folder = extra_catalogues({"de": filler("Deutsch")})
    stored = load_study(write_study(tmp_path, with_german(default_document())))
    shutil.rmtree(folder / "de")
    rebuilt = study_from_config(stored.config)  # data collected under it stays readable
    assert rebuilt.content_hash == stored.content_hash
    [warning] = catalogue_warnings(rebuilt)
    assert warning.startswith("languages[2]: 'de' has no translation of the phone's own texts")
