"""Speech fallback: a sentence the wizard types when no prompt answers the participant (the
paper names this as a main problem of its Wizard-of-Oz set-up), spoken in the actor's
synthetic voice and logged as a deviation with its text.

The sentence is synthesised with espeak-ng using the actor's ``voice`` hints from
``actor.yaml`` (the demo voices' own settings), written once per (voice, text) as a WAV
under ``<data_dir>/typed-speech`` with a jaw-opening curve from its loudness, and played
like any prompt: ``prompt.played`` with ``typed: true`` (so acks, speech start/end and
"not voiced" are tracked as for recorded prompts), plus ``wizard.typed_speech`` on the
timeline and in the export, which the PI counts as deviations.

A booth whose robot has its own TTS (a Furhat: the worker's hello names the driver) gets the
text instead of a WAV: the worker says it with ``request.speak.text`` in the actor's Furhat
voice from the study (``actors.<id>.voice.furhat``; none: the robot's current voice), and
its speech start and end are tracked like a prompt's. The play's payload then says
``robot_tts: true`` and names the ``voice``; nothing is synthesised on the server.

    GET /media/typed/<digest>.wav|.csv?key=<token>   the audio and its lip-sync curve
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import subprocess
import tempfile
import wave
from collections.abc import Mapping
from dataclasses import dataclass
from functools import partial
from pathlib import Path, PurePosixPath
from types import SimpleNamespace
from typing import Annotated, Any, cast

import numpy as np
from fastapi import FastAPI, HTTPException, Query, Request, status
from fastapi.responses import FileResponse
from sqlalchemy.orm import Session

from chameleons.backend.display.tokens import check_token, media_token, signing_key
from chameleons.backend.events import repository as events
from chameleons.backend.models.base import utcnow
from chameleons.backend.routing import make_router
from chameleons.backend.studies.errors import ConflictError
from chameleons.backend.wizard import repository, service
from chameleons.backend.wizard.service import Cue
from chameleons.prompts import Prompt, Stage, estimate_duration
from chameleons.settings import Settings

router = make_router(tags=["wizard"])
FOLDER = "typed-speech"
MEDIA_SCOPE = "typed-speech"  # media tokens are per actor; typed files share one scope
LIPSYNC_RATE = 30
TYPED_KIND = "wizard.typed_speech"
ESPEAK_FLAGS = {"speed": "-s", "amplitude": "-a", "pitch": "-p", "word_gap": "-g"}
MAX_TEXT = 500


class SpeechUnavailableError(ConflictError):
    """espeak-ng is missing or failed: said in one sentence, nothing is played."""


@dataclass(frozen=True)
class TypedAudio:
    digest: str
    wav: Path
    duration: float


@dataclass(frozen=True)
class RobotSpeech:
    """Typed speech for the robot's own TTS: what it says and in which voice."""

    text: str
    voice: str | None
    duration: float  # estimated: the robot says when it really ends


INSTALL_HINT = "Debian/Ubuntu: apt install espeak-ng; macOS: brew install espeak-ng"


@dataclass(frozen=True)
class SynthesiserStatus:
    """Whether this server can synthesise typed speech, in one sentence either way."""

    available: bool
    detail: str


def check_synthesiser() -> SynthesiserStatus:
    """Look for a working espeak-ng (the server's start-up does, so the wizard learns it on
    the health strip before the session, not from a refused sentence in the middle of it)."""
    program = shutil.which("espeak-ng")
    if program is None:
        return SynthesiserStatus(False, f"espeak-ng not installed ({INSTALL_HINT})")
    try:
        done = subprocess.run([program, "--version"], capture_output=True, text=True,
                              timeout=10, check=False)  # fmt: skip
    except (OSError, subprocess.TimeoutExpired) as exc:
        return SynthesiserStatus(False, f"espeak-ng does not run: {exc}")
    if done.returncode != 0:
        lines = (done.stderr or done.stdout).strip().splitlines()
        why = lines[0] if lines else f"exit status {done.returncode}"
        return SynthesiserStatus(False, f"espeak-ng does not run: {why}")
    version = done.stdout.split(":", 1)[-1].split()[:1]  # "eSpeak NG text-to-speech: 1.51 ..."
    return SynthesiserStatus(True, f"espeak-ng {version[0]}" if version else "espeak-ng")


def synthesiser_of(state: Any) -> SynthesiserStatus | None:
    """What the start-up found (None: this app was not started through its lifespan)."""
    found = getattr(state, "typed_speech", None)
    return found if isinstance(found, SynthesiserStatus) else None


def folder(settings: Settings) -> Path:
    return settings.data_dir / FOLDER


def synthesize(settings: Settings, voice: Mapping[str, Any], text: str) -> TypedAudio:
    """The WAV (and lip-sync CSV) of ``text`` in ``voice``, made once and then reused."""
    digest = _digest(voice, text)
    target = folder(settings) / f"{digest}.wav"
    if not target.is_file():
        _espeak_to(target, voice, text)
        _write_lipsync(target, target.with_suffix(".csv"))
    with wave.open(str(target), "rb") as audio:
        duration = audio.getnframes() / float(audio.getframerate())
    return TypedAudio(digest, target, round(duration, 2))


def _espeak_to(target: Path, voice: Mapping[str, Any], text: str) -> None:
    program = shutil.which("espeak-ng")
    if program is None:
        raise SpeechUnavailableError(
            "Typed speech needs espeak-ng on the server (Debian/Ubuntu: apt install espeak-ng)."
        )
    args = [program, "-v", str(voice.get("espeak_voice", "en"))]
    args += [item for name, flag in ESPEAK_FLAGS.items() if name in voice
             for item in (flag, str(voice[name]))]  # fmt: skip
    target.parent.mkdir(parents=True, exist_ok=True)
    handle, temporary = tempfile.mkstemp(suffix=".wav", dir=target.parent)
    os.close(handle)
    try:
        # "--" ends the options: a sentence starting with "-" is text, not a flag.
        done = subprocess.run([*args, "-w", temporary, "--", text], capture_output=True,
                              text=True, timeout=60, check=False)  # fmt: skip
        if done.returncode != 0:
            raise SpeechUnavailableError(f"espeak-ng could not say it: {done.stderr.strip()}")
        os.replace(temporary, target)
    finally:
        Path(temporary).unlink(missing_ok=True)


def _write_lipsync(wav_path: Path, csv_path: Path) -> None:
    """A jaw-opening curve at 30 Hz from the audio's loudness (the catalogue's CSV columns)."""
    with wave.open(str(wav_path), "rb") as audio:
        rate, frames = audio.getframerate(), audio.readframes(audio.getnframes())
    samples = np.frombuffer(frames, dtype=np.int16).astype(np.float64) / 32768.0
    hop = max(1, rate // LIPSYNC_RATE)
    steps = max(1, len(samples) // hop)
    rms = np.sqrt(np.mean(samples[: steps * hop].reshape(steps, hop) ** 2, axis=1))
    top = float(np.percentile(rms, 95)) or 1.0
    jaw = np.clip(rms / top, 0.0, 1.0) * 0.6
    rows = (f"{i / LIPSYNC_RATE:.3f},{value:.3f}" for i, value in enumerate(jaw))
    lines = ["time,jawOpen", *rows]
    csv_path.write_text("\n".join(lines) + "\n")


def media_url(state: Any, digest: str, suffix: str = ".wav") -> str:
    key = signing_key(cast(FastAPI, SimpleNamespace(state=state)))
    token = media_token(key, MEDIA_SCOPE)
    return f"{state.settings.effective_public_url}/media/typed/{digest}{suffix}?key={token}"


def start_typed(
    db: Session, state: Any, session_id: int, text: str, robot_tts: bool = False
) -> tuple[Cue, TypedAudio | RobotSpeech]:
    """Log the click and prepare ``text`` in the current interaction's actor voice: a WAV
    from espeak-ng, or (``robot_tts``) the text and the actor's voice for the robot's TTS."""
    clicked_at = utcnow()
    view = service.speaking(db, session_id)
    interaction = view.current
    if interaction is None:
        raise ConflictError("This session has no current interaction to speak in.")
    spoken = (_robot_speech(view, interaction.actor, text) if robot_tts
              else _espeak_speech(state, view, interaction.actor, text))  # fmt: skip
    digest = spoken.digest if isinstance(spoken, TypedAudio) else _digest({"robot": True}, text)
    audio = PurePosixPath(spoken.wav.name) if isinstance(spoken, TypedAudio) else None
    prompt = Prompt(id=f"typed-{digest[:12]}", stage=Stage.CANNOT_ANSWER, group="typed",
                    text=text, audio=audio, estimated_duration=spoken.duration)  # fmt: skip
    log = partial(events.record, db, source="wizard", study_id=view.session.study_id,
                  session_id=session_id, interaction_id=interaction.id, at=clicked_at)  # fmt: skip
    payload = {"prompt_id": prompt.id, "group": "typed", "stage": "typed", "typed": True,
               "text": text, "duration": spoken.duration, "has_audio": audio is not None,
               "actor": interaction.actor, "position": interaction.position}  # fmt: skip
    if isinstance(spoken, TypedAudio):
        payload["audio_digest"] = spoken.digest
    else:
        payload.update(robot_tts=True, voice=spoken.voice)
    event = log(repository.PLAYED, payload=payload)
    log(TYPED_KIND, payload={"text": text, "actor": interaction.actor,
                             "position": interaction.position, "step": interaction.state,
                             "play_event_id": event.id})  # fmt: skip
    cue = Cue(event_id=event.id, study_id=view.session.study_id, session_id=session_id,
              interaction_id=interaction.id, booth=view.session.booth, actor=interaction.actor,
              prompt=prompt, duration=spoken.duration, clicked_at=clicked_at, audio=None,
              lipsync=None)  # fmt: skip
    return cue, spoken


def _espeak_speech(state: Any, view: Any, actor: str, text: str) -> TypedAudio:
    # The actor's voice in the session's language (prompts/<lang>/<actor>/actor.yaml).
    catalogue = service._catalogue(state, actor, view.session.language)
    return synthesize(state.settings, catalogue.profile.voice, text)


def _robot_speech(view: Any, actor: str, text: str) -> RobotSpeech:
    """The actor's Furhat voice in the session's language, when the study names one."""
    try:
        voice = view.spec.actor(actor).voice.furhat_voice(view.session.language)
    except KeyError:  # an actor the study no longer lists: the robot's own voice
        voice = None
    return RobotSpeech(text, voice, estimate_duration(text))


def _digest(voice: Mapping[str, Any], text: str) -> str:
    key = json.dumps({"voice": dict(voice), "text": text}, sort_keys=True)
    return hashlib.sha256(key.encode()).hexdigest()[:24]


@router.get("/media/typed/{name}")
def typed_media(
    name: str, request: Request, key: Annotated[str | None, Query()] = None
) -> FileResponse:
    """A typed sentence's WAV or lip-sync CSV, for the display page and a Furhat."""
    state = request.app.state
    expected = media_token(signing_key(request.app), MEDIA_SCOPE)
    stem, _, suffix = name.rpartition(".")
    if not check_token(expected, key):
        raise HTTPException(status.HTTP_403_FORBIDDEN, "This media link is not valid.")
    if not stem.isalnum() or suffix not in ("wav", "csv"):
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such typed sentence.")
    path = folder(state.settings) / f"{stem}.{suffix}"
    if not path.is_file():
        raise HTTPException(status.HTTP_404_NOT_FOUND, "No such typed sentence.")
    media = "audio/wav" if suffix == "wav" else "text/csv; charset=utf-8"
    return FileResponse(path, media_type=media, headers={"Cache-Control": "no-store"})
