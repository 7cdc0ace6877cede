"""Prompt audio and lip-sync files by URL, for display pages and for a Furhat.

``GET /media/prompts/<actor>/<path>?key=<media token>`` serves a file of the actor's
prompt folder (``Settings.prompts_dir``, resolved like the wizard console does);
``&lang=<language>`` serves it from the actor's folder of that language
(``prompts/<language>/<actor>/``, where a catalogue in another language lives: its files
have the same names as the main language's, so a URL without the language would serve the
wrong recording). The URL builders take the language from the prompt's catalogue. The
committed MP3s (Chromium, Firefox and Safari all play MP3; Ogg/Opus files are served too,
but Safari before 17 cannot play them) and the lip-sync CSVs. Asking for ``<name>.wav``
where only ``<name>.mp3``/``.ogg``/``.opus``/``.flac`` exists returns a 16-bit PCM mono
WAV decoded on first request and cached under ``<data_dir>/media-cache`` (mirroring the
prompts folder, so each language's files have their own cache). The play
command's URL (:func:`prompt_audio_url_builder`) is that WAV: a Furhat needs WAV
(``request.speak.audio``) and every browser plays PCM WAV too, so one URL serves both
robots. Staff may fetch without the key.

Browsers: Chromium, Firefox and Safari play both the MP3 and the WAV. Safari (and any
browser without ``--autoplay-policy=no-user-gesture-required``) plays sound only after a
user gesture on the page: click or tap the booth screen once after opening the display;
the page then reuses that unlocked audio element for every prompt.
"""

from __future__ import annotations

import os
import re
import tempfile
from collections.abc import Callable
from pathlib import Path, PurePosixPath
from typing import Annotated, Final
from urllib.parse import parse_qs, quote, unquote, urlencode, urlsplit, urlunsplit

from fastapi import FastAPI, HTTPException, Query, Request, status
from fastapi.responses import FileResponse

from chameleons.backend.auth import sessions as staff_sessions
from chameleons.backend.db import session_scope
from chameleons.backend.display.tokens import check_token, media_token, signing_key
from chameleons.backend.routing import make_router
from chameleons.backend.wizard.catalogues import prompts_root
from chameleons.experiment.languages import LANGUAGE
from chameleons.settings import Settings

router = make_router(tags=["display"])

MEDIA_TYPES: Final = {
    ".mp3": "audio/mpeg", ".ogg": "audio/ogg", ".opus": "audio/ogg", ".wav": "audio/wav",
    ".flac": "audio/flac", ".csv": "text/csv; charset=utf-8",
}  # fmt: skip
TRANSCODE_SOURCES: Final = (".mp3", ".ogg", ".opus", ".flac")
_TYPED_URL = re.compile(r"^/media/typed/(?P<digest>[0-9a-f]+)\.wav$")
_AUDIO_URL = re.compile(r"^/media/prompts/(?P<actor>[^/]+)/audio/(?P<stem>[^/]+)\.\w+$")


def media_path(
    key: bytes,
    actor: str,
    relative: str | PurePosixPath,
    *,
    wav: bool = False,
    language: str | None = None,
) -> str:
    """The URL path (with key) of a prompt file; ``wav=True`` asks for the WAV version;
    ``language`` is the language folder the file lies in (None: the actor's own folder)."""
    rel = PurePosixPath(str(relative))
    if wav:
        rel = rel.with_suffix(".wav")
    query = {"key": media_token(key, actor)} | ({"lang": language} if language else {})
    return f"/media/prompts/{quote(actor)}/{quote(str(rel))}?{urlencode(query)}"


def prompt_audio_url_builder(app: FastAPI) -> Callable[[str, str, str | None], str]:
    """``(actor, audio path from the manifest, language folder or None) -> absolute WAV URL
    with key``."""
    settings: Settings = app.state.settings

    def build(actor: str, audio: str, language: str | None = None) -> str:
        path = media_path(signing_key(app), actor, audio, wav=True, language=language)
        return settings.effective_public_url + path

    return build


def lipsync_url_for(settings: Settings, audio_url: str) -> str | None:
    """The lip-sync CSV URL of a prompt audio URL built here, by the assets' convention
    (``audio/<id>.<ext>`` beside ``lipsync/<id>.csv``, in the same language folder), when
    that file exists."""
    parts = urlsplit(audio_url)
    typed = _TYPED_URL.match(unquote(parts.path))
    if typed is not None:  # a typed sentence's curve lies beside its WAV
        origin = urlunsplit((parts.scheme, parts.netloc, "", "", ""))
        return f"{origin}/media/typed/{typed.group('digest')}.csv?{parts.query}"
    match = _AUDIO_URL.match(unquote(parts.path))
    if match is None:
        return None
    actor, stem = match.group("actor"), match.group("stem")
    language = next(iter(parse_qs(parts.query).get("lang", [])), None)
    try:
        curves = _actor_dir(settings, actor, language) / "lipsync" / f"{stem}.csv"
    except HTTPException:
        return None
    if not curves.is_file():
        return None
    path = f"/media/prompts/{quote(actor)}/lipsync/{quote(stem)}.csv?{parts.query}"
    return urlunsplit((parts.scheme, parts.netloc, "", "", "")) + path


def _actor_dir(settings: Settings, actor: str, language: str | None) -> Path:
    """The actor's folder (in ``language``'s folder when given): one plain folder name
    under the prompts folder (an actor folder may be a symbolic link the lab made); 404 for
    anything else."""
    root = prompts_root(settings).resolve()
    if language is not None and not LANGUAGE.match(language):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such prompt file.")
    if actor in ("", ".", "..") or "/" in actor or "\\" in actor:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such prompt file.")
    return (root / actor if language is None else root / language / actor).resolve()


def _actor_file(settings: Settings, actor: str, relative: str, language: str | None) -> Path:
    actor_dir = _actor_dir(settings, actor, language)
    path = (actor_dir / relative).resolve()
    if not path.is_relative_to(actor_dir) or path.suffix.lower() not in MEDIA_TYPES:
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such prompt file.")
    return path


def _staff_session(request: Request) -> bool:
    """A logged-in staff member (an open server-side session), checked only without a key."""
    with session_scope(request.app.state.sessionmaker) as db:
        return staff_sessions.staff_of(db, request.session) is not None


@router.get("/media/prompts/{actor}/{relative:path}", name="prompt_media")
def prompt_media(
    request: Request,
    actor: str,
    relative: str,
    key: Annotated[str | None, Query()] = None,
    lang: Annotated[str | None, Query()] = None,
) -> FileResponse:
    if not check_token(media_token(signing_key(request.app), actor), key) and not (
        _staff_session(request)
    ):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such prompt file.")
    settings: Settings = request.app.state.settings
    path = _actor_file(settings, actor, relative, lang)
    if not path.is_file() and path.suffix.lower() == ".wav":
        inside = path.relative_to(_actor_dir(settings, actor, lang))
        path = _cached_wav(settings, path, Path(lang or "", actor, inside))
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such prompt file.")
    return FileResponse(path, media_type=MEDIA_TYPES[path.suffix.lower()])


def _cached_wav(settings: Settings, wav_path: Path, relative: Path) -> Path:
    """The WAV decoded from the same-named MP3/Ogg/FLAC beside ``wav_path``, cached under
    ``<data_dir>/media-cache`` at ``relative``, its place under the prompts folder (so
    ``sv/m1/audio/x.wav`` and ``m1/audio/x.wav`` never share a cache entry)."""
    source = next(
        (s for s in (wav_path.with_suffix(x) for x in TRANSCODE_SOURCES) if s.is_file()), None
    )
    if source is None:
        return wav_path
    cached = settings.data_dir / "media-cache" / relative
    if not cached.is_file() or cached.stat().st_mtime < source.stat().st_mtime:
        transcode_to_wav(source, cached)
    return cached


def transcode_to_wav(source: Path, target: Path) -> None:
    """Decode ``source`` to 16-bit PCM mono WAV, written atomically (concurrent requests)."""
    import soundfile  # libsndfile decodes MP3, Ogg Vorbis/Opus and FLAC

    data, rate = soundfile.read(source, dtype="int16", always_2d=True)
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(suffix=".wav", dir=target.parent)
    os.close(handle)
    try:
        soundfile.write(temporary, data.mean(axis=1).astype("int16"), rate, subtype="PCM_16")
        os.replace(temporary, target)
    finally:
        if os.path.exists(temporary):
            os.unlink(temporary)
