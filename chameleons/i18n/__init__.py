"""The participant's language: message catalogues for the phone pages and the phone script.

Two gettext domains live in ``chameleons/locale/``: ``messages`` (the phone's templates and
the server's sentences to the phone) and ``phone`` (the strings of ``static/phone/*.js``,
served to the script as a JSON catalogue). English is the source language: its texts are
the message ids, so English needs no catalogue. Each other language has
``<lang>/LC_MESSAGES/<domain>.po``.

The ``.po`` files are read directly (compiled in memory at first use, a few milliseconds),
so a fresh clone works without a build step; a ``.mo`` beside a ``.po`` (``make
i18n-compile``) is used instead when it is newer. See docs/designing-a-study.md, "Languages".
"""

from __future__ import annotations

import functools
import io
from gettext import NullTranslations
from pathlib import Path

LOCALE_DIR = Path(__file__).resolve().parent.parent / "locale"
SOURCE_LANGUAGE = "en"
DOMAINS = ("messages", "phone")
# Scripts written right to left (ISO 639-1): the phone pages get dir="rtl".
RTL_LANGUAGES = frozenset({"ar", "dv", "fa", "he", "ku", "ps", "sd", "ug", "ur", "yi"})


def N_(message: str) -> str:  # noqa: N802 - the gettext convention for "mark, translate later"
    """Marks a sentence for extraction; it is translated where it is shown."""
    return message


def text_direction(language: str) -> str:
    return "rtl" if language.split("-")[0].lower() in RTL_LANGUAGES else "ltr"


def catalogue_languages() -> tuple[str, ...]:
    """English plus every language with a catalogue of the phone's texts."""
    found = sorted(p.name for p in LOCALE_DIR.iterdir() if (p / "LC_MESSAGES").is_dir())
    return (SOURCE_LANGUAGE, *[lang for lang in found if lang != SOURCE_LANGUAGE])


def has_phone_catalogue(language: str) -> bool:
    """Whether the phone can show its own texts in ``language``: English (any region) is
    the source language; every other needs both domains' ``.po``."""
    if language.split("-")[0].lower() == SOURCE_LANGUAGE:
        return True
    folder = LOCALE_DIR / language / "LC_MESSAGES"
    return all((folder / f"{domain}.po").is_file() for domain in DOMAINS)


def untranslated_phone_texts(language: str) -> int:
    """How many of the templates' entries (``<domain>.pot``) ``language``'s catalogues lack,
    leave empty or mark fuzzy: the phone shows those in English."""
    if language.split("-")[0].lower() == SOURCE_LANGUAGE:
        return 0
    files = [LOCALE_DIR / language / "LC_MESSAGES" / f"{d}.po" for d in DOMAINS]
    files += [LOCALE_DIR / f"{d}.pot" for d in DOMAINS]
    stamp = tuple(f.stat().st_mtime_ns if f.is_file() else 0 for f in files)
    return _untranslated(LOCALE_DIR, language, stamp)


@functools.lru_cache(maxsize=32)
def _untranslated(locale_dir: Path, language: str, _stamp: tuple[int, ...]) -> int:
    """Cached per language and the files' times, so an edited catalogue is read again."""
    from babel.messages.pofile import read_po

    missing = 0
    for domain in DOMAINS:
        template = locale_dir / f"{domain}.pot"
        po = locale_dir / language / "LC_MESSAGES" / f"{domain}.po"
        if not template.is_file():
            continue
        with template.open("rb") as handle:
            wanted = [m.id for m in read_po(handle) if m.id]
        if not po.is_file():
            missing += len(wanted)
            continue
        with po.open("rb") as handle:
            catalog = read_po(handle, locale=language)
        for message_id in wanted:
            message = catalog.get(message_id)
            missing += message is None or not message.string or message.fuzzy
    return missing


@functools.cache
def translations(language: str, domain: str = "messages") -> NullTranslations:
    """The catalogue of ``language``; English (or a language without one) translates
    nothing, so the English source text is shown."""
    # Babel is imported here: the experiment core marks texts with N_ without needing it.
    from babel.messages.mofile import write_mo
    from babel.messages.pofile import read_po
    from babel.support import Translations

    po = LOCALE_DIR / language / "LC_MESSAGES" / f"{domain}.po"
    if language == SOURCE_LANGUAGE or not po.is_file():
        return NullTranslations()
    mo = po.with_suffix(".mo")
    if mo.is_file() and mo.stat().st_mtime >= po.stat().st_mtime:
        with mo.open("rb") as handle:
            return Translations(handle, domain=domain)
    with po.open("rb") as handle:
        catalog = read_po(handle, locale=language, domain=domain)
    buffer = io.BytesIO()
    write_mo(buffer, catalog)  # fuzzy entries are left out, as pybabel compile does
    buffer.seek(0)
    return Translations(buffer, domain=domain)


@functools.cache
def script_catalogue(language: str) -> dict[str, str]:
    """The phone script's strings in ``language`` (message id -> translation); the script
    shows the message id itself for anything missing."""
    from babel.messages.pofile import read_po

    po = LOCALE_DIR / language / "LC_MESSAGES" / "phone.po"
    if language == SOURCE_LANGUAGE or not po.is_file():
        return {}
    with po.open("rb") as handle:
        catalog = read_po(handle, locale=language, domain="phone")
    return {
        str(m.id): str(m.string)
        for m in catalog
        if m.id and isinstance(m.id, str) and m.string and not m.fuzzy
    }


@functools.cache
def language_name(language: str) -> str:
    """A language's own name for itself ("svenska", "English"), for choosing it."""
    from babel import Locale, UnknownLocaleError

    try:
        name = Locale.parse(language.replace("-", "_")).get_display_name(language.replace("-", "_"))
    except (ValueError, UnknownLocaleError):
        return language
    return name[:1].upper() + name[1:] if name else language


def preferred_language(accept_language: str) -> str:
    """The first language of an ``Accept-Language`` header that has a catalogue (by weight,
    then order), else English."""
    available = set(catalogue_languages())
    ranked: list[tuple[float, int, str]] = []
    for index, part in enumerate(accept_language.split(",")[:20]):
        tag, _, quality = part.strip().partition(";q=")
        code = tag.split("-")[0].strip().lower()
        try:
            weight = float(quality) if quality else 1.0
        except ValueError:
            continue
        if code in available:
            ranked.append((-weight, index, code))
    return min(ranked)[2] if ranked else SOURCE_LANGUAGE


def gettext(language: str, message: str, **params: object) -> str:
    """``message`` in ``language``, with ``{name}`` placeholders filled in."""
    text = translations(language).gettext(message)
    return text.format(**params) if params else text
