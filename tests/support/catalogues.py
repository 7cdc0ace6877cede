"""Catalogues of the phone's own texts for languages the repository does not ship.

A study may only declare a language the phone has a catalogue for, so a test in Arabic or
German first writes one: a copy of ``chameleons/locale`` plus a catalogue per language made
from the templates (``.pot``), each entry "translated" by a function the test gives. The
app reads that folder for the rest of the test (the server runs in the test's process).
"""

from __future__ import annotations

import re
import shutil
from collections.abc import Callable, Iterator, Mapping
from pathlib import Path

import pytest
from babel.messages.catalog import Catalog
from babel.messages.pofile import read_po, write_po

import chameleons.i18n as i18n

Translate = Callable[[str], str]
MakeCatalogues = Callable[[Mapping[str, Translate]], Path]
PLACEHOLDER = re.compile(r"\{\w+\}")


def filler(text: str) -> Translate:
    """A stand-in translation: ``text`` followed by the entry's own ``{placeholders}``."""
    return lambda message_id: " ".join([text, *PLACEHOLDER.findall(message_id)])


def write_catalogue(folder: Path, language: str, domain: str, translate: Translate) -> None:
    """``folder/<language>/LC_MESSAGES/<domain>.po`` from ``folder``'s template."""
    with (folder / f"{domain}.pot").open("rb") as handle:
        template = read_po(handle)
    catalog = Catalog(locale=language.replace("-", "_"), domain=domain)
    for message in template:
        if message.id:
            catalog.add(message.id, translate(str(message.id)))
    target = folder / language / "LC_MESSAGES" / f"{domain}.po"
    target.parent.mkdir(parents=True, exist_ok=True)
    with target.open("wb") as handle:
        write_po(handle, catalog)


def _forget() -> None:
    i18n.translations.cache_clear()
    i18n.script_catalogue.cache_clear()
    i18n.language_name.cache_clear()


@pytest.fixture
def extra_catalogues(monkeypatch: pytest.MonkeyPatch, tmp_path: Path) -> Iterator[MakeCatalogues]:
    """``extra_catalogues({"ar": filler("نص")})``: the shipped catalogues plus these."""

    shipped = i18n.LOCALE_DIR
    made: list[Path] = []

    def make(languages: Mapping[str, Translate]) -> Path:
        folder = tmp_path / f"locale-{len(made)}"  # a new folder each time: no stale cache
        made.append(folder)
        shutil.copytree(shipped, folder, ignore=shutil.ignore_patterns("*.mo"))
        for language, translate in languages.items():
            for domain in i18n.DOMAINS:
                write_catalogue(folder, language, domain, translate)
        monkeypatch.setattr(i18n, "LOCALE_DIR", folder)
        _forget()
        return folder

    yield make
    _forget()  # before the monkeypatch is undone: the next reads are of the real folder
