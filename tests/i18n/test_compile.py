"""Every catalogue compiles cleanly, as ``make i18n-compile`` would compile it.

The app reads the ``.po`` files itself, so nothing else would notice a catalogue that
``pybabel compile`` refuses or quietly shortens: a syntax error (the entry is dropped with
a printed warning), a catalogue marked fuzzy (skipped whole), a fuzzy entry (left out), a
``%``-format mismatch (an error), or a ``{placeholder}`` the translation lost (the phone
would show it raw). Compiling runs here with Babel's own compile command on a copy of the
catalogues, so ``make test`` (which CI runs) covers the compile step too; the ``.mo``
files it writes are read back and must hold every translation.
"""

from __future__ import annotations

import logging
import re
import shutil
from collections.abc import Iterable
from gettext import GNUTranslations
from pathlib import Path

import pytest
from babel.messages.frontend import CompileCatalog
from babel.messages.pofile import PoFileError, read_po

from chameleons.i18n import DOMAINS, LOCALE_DIR

PLACEHOLDER = re.compile(r"\{(\w+)\}")


class _Collect(logging.Handler):
    def __init__(self) -> None:
        super().__init__(logging.WARNING)
        self.lines: list[str] = []

    def emit(self, record: logging.LogRecord) -> None:
        self.lines.append(record.getMessage())


def _texts(value: str | Iterable[str]) -> list[str]:
    """A message's id or translation as texts (a plural entry has several)."""
    return [value] if isinstance(value, str) else list(value)


def _read_problems(po: Path, language: str) -> list[str]:
    """What compiling would drop or get wrong in one ``.po`` (beyond Babel's checks)."""
    try:
        with po.open("rb") as handle:
            catalog = read_po(handle, locale=language, abort_invalid=True)
    except PoFileError as exc:
        return [f"{po}: not a valid catalogue: {exc}"]
    problems = [f"{po}: the catalogue is marked fuzzy (compiling skips it)"] * catalog.fuzzy
    for message in catalog:
        if not message.id or not message.string:
            continue
        if message.fuzzy:
            problems.append(f"{po}:{message.lineno}: fuzzy (left out when compiled)")
        wanted = {name for text in _texts(message.id) for name in PLACEHOLDER.findall(text)}
        for text in _texts(message.string):
            if set(PLACEHOLDER.findall(text)) != wanted:
                problems.append(f"{po}:{message.lineno}: placeholders differ from {sorted(wanted)}")
    return problems


def compile_problems(locale_dir: Path, domain: str, work: Path) -> list[str]:
    """Every error and warning from compiling ``domain`` of ``locale_dir`` (in ``work``)."""
    shutil.copytree(locale_dir, work, ignore=shutil.ignore_patterns("*.mo", "*.pot"))
    pos = sorted(work.glob(f"*/LC_MESSAGES/{domain}.po"))
    problems = [p for po in pos for p in _read_problems(po, po.parent.parent.name)]
    command = CompileCatalog()  # type: ignore[no-untyped-call]
    command.initialize_options()  # type: ignore[no-untyped-call]
    command.domain = domain
    command.directory = str(work)
    command.statistics = True
    command.finalize_options()  # type: ignore[no-untyped-call]
    collect = _Collect()
    logger = logging.getLogger("babel")
    logger.addHandler(collect)
    try:
        status = command.run()  # type: ignore[no-untyped-call]
    finally:
        logger.removeHandler(collect)
    problems += collect.lines + [f"pybabel compile exited with {status}"] * (status != 0)
    for po in pos:
        problems += _missing_after_compiling(po)
    return problems


def _missing_after_compiling(po: Path) -> list[str]:
    mo = po.with_suffix(".mo")
    if not mo.is_file():
        return [f"{po}: no .mo was written"]
    with po.open("rb") as handle:
        catalog = read_po(handle)
    with mo.open("rb") as handle:
        compiled = GNUTranslations(handle)
    return [
        f"{po}:{m.lineno}: missing from the compiled catalogue"
        for m in catalog
        if m.id and isinstance(m.id, str) and m.string and compiled.gettext(m.id) != m.string
    ]


@pytest.mark.parametrize("domain", DOMAINS)
def test_every_catalogue_compiles_without_errors_or_warnings(domain: str, tmp_path: Path) -> None:
    languages = [p.parent.parent.name for p in LOCALE_DIR.glob(f"*/LC_MESSAGES/{domain}.po")]
    assert "sv" in languages  # the check really compiled a catalogue
    assert compile_problems(LOCALE_DIR, domain, tmp_path / "locale") == []


BROKEN = r"""msgid ""
msgstr ""
"Language: sv\n"
"Content-Type: text/plain; charset=utf-8\n"

msgid "Fine"
msgstr "Bra"

#, python-format
msgid "%(count)d items"
msgstr "%(antal)d föremål"

msgid "Please answer question {number}."
msgstr "Svara på frågan."

#, fuzzy
msgid "Next"
msgstr "Nästa"
"""


def test_the_check_finds_what_compiling_would_get_wrong(tmp_path: Path) -> None:
    """The same check on a catalogue with a format error, a lost placeholder and a fuzzy
    entry reports each of them (so a clean result above means something)."""
    source = tmp_path / "source"
    (source / "sv" / "LC_MESSAGES").mkdir(parents=True)
    (source / "sv" / "LC_MESSAGES" / "messages.po").write_text(BROKEN, encoding="utf-8")
    problems = compile_problems(source, "messages", tmp_path / "work")
    assert any("placeholders differ from ['number']" in p for p in problems), problems
    assert any("fuzzy (left out when compiled)" in p for p in problems), problems
    assert any("unknown named placeholder 'antal'" in p for p in problems), problems
    assert "pybabel compile exited with 1" in problems
    assert not any("Fine" in p or "Bra" in p for p in problems)
