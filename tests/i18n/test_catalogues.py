"""The participant's texts are all in the catalogues, and every declared language has them.

Extraction runs here exactly as ``make i18n-extract`` does (the same ``babel.cfg`` and
``babel-js.cfg``), so a new sentence on the phone that nobody translated fails the suite;
so does a phone template or script that shows English text without marking it."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from babel.messages.extract import extract_from_dir
from babel.messages.frontend import parse_mapping_cfg
from babel.messages.pofile import read_po

from chameleons.i18n import LOCALE_DIR, catalogue_languages, gettext, script_catalogue

ROOT = Path(__file__).resolve().parents[2]
FRONTEND = ROOT / "chameleons" / "frontend"
# The JavaScript domain has one keyword, the script's t("..."); Python and Jinja use the
# default gettext keywords (_, gettext, N_, ...).
DOMAINS: dict[str, tuple[str, dict[str, None] | None]] = {
    "messages": ("babel.cfg", None),
    "phone": ("babel-js.cfg", {"t": None}),
}
PLACEHOLDER = re.compile(r"\{(\w+)\}")


def extracted(domain: str) -> set[str]:
    config, keywords = DOMAINS[domain]
    with (ROOT / config).open(encoding="utf-8") as handle:
        method_map, options_map = parse_mapping_cfg(handle)  # type: ignore[no-untyped-call]
    if keywords is None:
        found = extract_from_dir(ROOT, method_map, options_map)
    else:
        found = extract_from_dir(ROOT, method_map, options_map, keywords=keywords)
    return {m if isinstance(m, str) else m[0] for _file, _line, m, _comments, _context in found}


def translated_languages() -> list[str]:
    return [lang for lang in catalogue_languages() if lang != "en"]


def test_swedish_is_a_declared_language() -> None:
    assert "sv" in translated_languages()


@pytest.mark.parametrize("domain", sorted(DOMAINS))
def test_the_templates_in_the_repository_are_up_to_date(domain: str) -> None:
    with (LOCALE_DIR / f"{domain}.pot").open("rb") as handle:
        in_pot = {m.id for m in read_po(handle) if m.id}
    found = extracted(domain)
    assert len(found) > 20  # the extraction really read the sources
    assert found == in_pot, "run `make i18n-extract` and translate the new entries"


@pytest.mark.parametrize("domain", sorted(DOMAINS))
@pytest.mark.parametrize("language", translated_languages())
def test_every_participant_string_is_translated(domain: str, language: str) -> None:
    with (LOCALE_DIR / language / "LC_MESSAGES" / f"{domain}.po").open("rb") as handle:
        catalog = read_po(handle, locale=language)
    untranslated = []
    for message_id in sorted(extracted(domain)):
        message = catalog.get(message_id)
        if message is None or not message.string or message.fuzzy:
            untranslated.append(message_id)
            continue
        # A translation keeps every placeholder, or the phone would show "{number}".
        assert set(PLACEHOLDER.findall(message_id)) == set(
            PLACEHOLDER.findall(str(message.string))
        ), message_id
    assert untranslated == [], f"{language}/{domain}.po lacks translations"


def _visible_text(template: str) -> str:
    """A template's text outside tags and Jinja expressions (what would show untranslated)."""
    text = re.sub(r"\{% block body_class %\}.*?\{% endblock %\}", " ", template)  # a class
    text = re.sub(r"\{\{.*?\}\}|\{%.*?%\}|\{#.*?#\}", " ", text, flags=re.S)
    text = re.sub(r"<script\b.*?</script>|<style\b.*?</style>", " ", text, flags=re.S)
    return re.sub(r"<[^>]*>", " ", text)


@pytest.mark.parametrize(
    "template", sorted((FRONTEND / "templates" / "phone").glob("*.html")), ids=lambda p: p.name
)
def test_phone_templates_have_no_bare_text(template: Path) -> None:
    leftover = _visible_text(template.read_text(encoding="utf-8"))
    assert re.findall(r"[A-Za-z]{2,}", leftover) == []


def test_the_phone_script_shows_no_bare_english() -> None:
    scripts = sorted((FRONTEND / "static" / "phone").glob("*.js"))
    assert len(scripts) > 1  # the page's modules, not only phone.js
    script = "\n".join(path.read_text(encoding="utf-8") for path in scripts)
    shown = re.findall(r'(?:text|"aria-label"|title):\s*"([^"]*[A-Za-z][^"]*)"', script)
    assert shown == []
    assert re.findall(r'(?:announce|showError)\("[^"]*[A-Za-z]', script) == []


def test_the_catalogues_translate_with_placeholders_filled() -> None:
    assert gettext("sv", "Please answer question {number}.", number=3) == "Svara på fråga 3."
    assert gettext("en", "Please answer question {number}.", number=3) == (
        "Please answer question 3."
    )
    assert script_catalogue("sv")["Rank the items"] == "Rangordna föremålen"
    assert script_catalogue("en") == {}
