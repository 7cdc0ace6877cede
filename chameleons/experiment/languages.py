"""Study texts in several languages.

A study declares ``languages: [en, sv]`` (the first is the default unless
``default_language`` says otherwise). Any text the participant sees (task names and
introductions, item names, questionnaire titles, items, anchors and options, consent and
debriefing) may then be a plain string (the same in every language) or a mapping per
language, ``{en: ..., sv: ...}``. Every mapping must give every declared language and no
other: a missing translation is a problem at its place (``file:line`` in a study file).
Every declared language but English also needs the phone's own texts translated
(``chameleons/locale/<lang>/``, see :mod:`chameleons.i18n`): a study file declaring one
without them is refused; a stored study only warns, as does a catalogue lacking some texts.

The loader builds the study once per language from :func:`resolve`\\ d copies of the
document; :func:`merge` folds the per-language snapshots into one, with a mapping wherever
the languages differ, so the content hash covers every translation and a snapshot rebuilds
the same study in every language.
"""

from __future__ import annotations

import re
from collections.abc import Mapping
from typing import Any

from chameleons.experiment.reader import Reader, join
from chameleons.i18n import has_phone_catalogue, untranslated_phone_texts

LANGUAGE = re.compile(r"^[a-z]{2,3}(-[A-Za-z0-9]{2,8})?$")
# Keys whose value is a text the participant may see (a study's own name and description
# too: harmless, and a lab may want them translated for its records).
TEXT_KEYS = frozenset(
    {"name", "description", "source", "introduction", "title", "text", "low", "high"}
    | {"left", "right", "label", "agree", "decline", "audio_label"}
)
# Sections only staff see, or that hold no texts: never translated.
STAFF_SECTIONS = frozenset(
    {"conditions", "actors", "faces", "robot_names", "personas", "design", "item_sets"}
)
DEFAULT_LANGUAGES = ("en",)


def read_languages(reader: Reader, top: Mapping[str, Any]) -> tuple[tuple[str, ...], str]:
    """(declared languages, default language); English alone when none are declared."""
    node = top.get("languages", list(DEFAULT_LANGUAGES))
    languages: list[str] = []
    for index, code in enumerate(reader.sequence(node, "languages")):
        if not isinstance(code, str) or not LANGUAGE.match(code):
            reader.problem(join("languages", index), f"{code!r} is not a language code (en, sv)")
        elif code in languages:
            reader.problem(join("languages", index), f"{code!r} listed twice")
        else:
            languages.append(code)
    if not languages:
        if "languages" in top:
            reader.problem("languages", "needs at least one language")
        languages = list(DEFAULT_LANGUAGES)
    default = top.get("default_language", languages[0])
    if default not in languages:
        reader.problem("default_language", f"{default!r} is not one of languages {languages}")
        default = languages[0]
    return tuple(languages), str(default)


def catalogue_notes(
    top: Mapping[str, Any], declared: tuple[str, ...]
) -> tuple[list[str], list[str]]:
    """(missing, incomplete): ``place: sentence`` for each declared language whose phone
    has no catalogue of its own texts (buttons, progress, errors, offline notices: they
    would stay in English), and for each whose catalogue lacks some of them."""
    listed = top.get("languages")
    listed = listed if isinstance(listed, list) else []
    missing: list[str] = []
    incomplete: list[str] = []
    for code in declared:
        place = join("languages", listed.index(code)) if code in listed else "languages"
        if not has_phone_catalogue(code):
            missing.append(
                f"{place}: {code!r} has no translation of the phone's own texts (buttons, "
                f"progress, errors, offline notices), which would stay in English. Add one: "
                f"`make i18n-extract`, then `pybabel init` a {code} catalogue for each domain "
                f'(docs/designing-a-study.md, "Adding a language") and translate '
                f"chameleons/locale/{code}/LC_MESSAGES/messages.po and phone.po"
            )
        elif count := untranslated_phone_texts(code):
            incomplete.append(
                f"{place}: {count} of the phone's own texts have no {code} translation in "
                f"chameleons/locale/{code}/LC_MESSAGES/ (the phone shows them in English; "
                f"`make test` fails until they are translated)"
            )
    return missing, incomplete


def is_translated(value: object) -> bool:
    return isinstance(value, Mapping)


def check(reader: Reader, node: object, languages: tuple[str, ...], path: str = "") -> None:
    """Report every text mapping that lacks a declared language or has another one."""
    if isinstance(node, Mapping):
        for key, value in node.items():
            place = join(path, str(key))
            if not path and key in STAFF_SECTIONS:
                continue
            if key in TEXT_KEYS and is_translated(value):
                _check_text(reader, value, languages, place)
            else:
                check(reader, value, languages, place)
    elif isinstance(node, list):
        for index, value in enumerate(node):
            check(reader, value, languages, join(path, index))


def _check_text(
    reader: Reader, text: Mapping[Any, Any], languages: tuple[str, ...], place: str
) -> None:
    given = [str(code) for code in text]
    for code in languages:
        value = text.get(code)
        if code not in text:
            reader.problem(place, f"has no {code} text (the study's languages: {list(languages)})")
        elif not isinstance(value, str) or not value.strip():
            reader.problem(join(place, code), "must be a non-empty text")
    for code in given:
        if code not in languages:
            reader.problem(
                join(place, code),
                f"is a language the study does not declare (languages: {list(languages)})",
            )


def resolve(node: Any, language: str, default: str, path: str = "") -> Any:
    """A copy of the document with every text mapping replaced by its ``language`` text
    (the default language's where that one is missing: problems were reported already)."""
    if isinstance(node, Mapping):
        resolved = {}
        for key, value in node.items():
            if not path and key in STAFF_SECTIONS:
                resolved[key] = value
            elif key in TEXT_KEYS and is_translated(value):
                resolved[key] = value.get(language, value.get(default))
            else:
                resolved[key] = resolve(value, language, default, join(path, str(key)))
        return resolved
    if isinstance(node, list):
        return [resolve(value, language, default, join(path, i)) for i, value in enumerate(node)]
    return node


def merge(configs: Mapping[str, Any], languages: tuple[str, ...]) -> Any:
    """One snapshot from the per-language snapshots (same shape, texts may differ): a text
    that differs between languages becomes ``{lang: text}`` in declared order."""
    first = configs[languages[0]]
    if isinstance(first, dict):
        return {
            key: merge({lang: c[key] for lang, c in configs.items()}, languages) for key in first
        }
    if isinstance(first, list):
        return [
            merge({lang: c[index] for lang, c in configs.items()}, languages)
            for index in range(len(first))
        ]
    if isinstance(first, str) and any(configs[lang] != first for lang in languages):
        return {lang: configs[lang] for lang in languages}
    return first
