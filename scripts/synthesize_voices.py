"""Synthesise the demo catalogue's voices with espeak-ng and derive their lip-sync curves.

For every prompt of every actor under ``prompts/`` this writes ``<actor>/audio/<id>.mp3``
(mono MP3, low bitrate: every browser plays it and the server decodes it to WAV for a
Furhat) and ``<actor>/lipsync/<id>.csv`` (30 Hz, the format of
:mod:`chameleons.worker.lipsync`), then fills only the ``audio`` and ``lipsync`` cells of
the actor's manifest. Each actor's voice comes from the ``voice`` hints of its
``actor.yaml`` (espeak-ng voice, pitch, speed, word gap, amplitude).

Lip-sync: espeak-ng's library reports every phoneme with its sample position; each phoneme
maps to a mouth shape (viseme: closed lips for p/b/m, lower lip tucked for f/v, rounded
for o/u/w, spread for i/e, open for a...), the shapes are blended across phoneme borders
(coarticulation) and the jaw follows the audio envelope. Without the library (no
``libespeak-ng.so.1``) the command-line espeak-ng is used and the curves come from the
envelope alone.

Rerunnable: a prompt is synthesised again only when its text or voice changed (hashes in
``<actor>/audio/.synthesized.json``) or with ``--force``. Needs espeak-ng and the
``soundfile`` wheel (libsndfile with MP3); the committed output needs neither.

Usage: ``.venv/bin/python scripts/synthesize_voices.py [--root prompts] [--actor m1 ...]
[--force] [--bitrate-quality 0.93]``
"""

from __future__ import annotations

import argparse
import ctypes
import hashlib
import io
import itertools
import json
import shutil
import subprocess
import sys
import tempfile
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt
import soundfile
from scipy.ndimage import gaussian_filter1d
from scipy.signal import resample_poly

from chameleons.prompts import Catalogue, load_catalogue
from chameleons.prompts.importer import set_manifest_assets
from chameleons.prompts.loader import actor_directories

ROOT = Path(__file__).resolve().parent.parent
LIPSYNC_RATE = 30
MP3_RATE = 16000
CURVE_RATE = 100  # phoneme shapes are built and smoothed at 10 ms, then sampled at 30 Hz
STAMP_NAME = ".synthesized.json"
Samples = npt.NDArray[np.int16]
Floats = npt.NDArray[np.float64]

# -- mouth shapes per espeak phoneme mnemonic (first matching prefix class wins) ----------
SHAPES: dict[str, dict[str, float]] = {
    "closed": {"jawOpen": 0.06, "mouthClose": 0.06, "mouthPressLeft": 0.45,
               "mouthPressRight": 0.45},
    "labiodental": {"jawOpen": 0.1, "mouthRollLower": 0.55, "mouthUpperUpLeft": 0.25,
                    "mouthUpperUpRight": 0.25},
    "rounded": {"jawOpen": 0.22, "mouthPucker": 0.6, "mouthFunnel": 0.35},
    "round_open": {"jawOpen": 0.38, "mouthFunnel": 0.55, "mouthPucker": 0.2},
    "spread": {"jawOpen": 0.18, "mouthStretchLeft": 0.4, "mouthStretchRight": 0.4,
               "mouthSmileLeft": 0.15, "mouthSmileRight": 0.15},
    "mid": {"jawOpen": 0.32, "mouthStretchLeft": 0.15, "mouthStretchRight": 0.15,
            "mouthLowerDownLeft": 0.2, "mouthLowerDownRight": 0.2},
    "open": {"jawOpen": 0.55, "mouthLowerDownLeft": 0.3, "mouthLowerDownRight": 0.3,
             "mouthUpperUpLeft": 0.1, "mouthUpperUpRight": 0.1},
    "schwa": {"jawOpen": 0.2, "mouthLowerDownLeft": 0.1, "mouthLowerDownRight": 0.1},
    "postalveolar": {"jawOpen": 0.14, "mouthFunnel": 0.5, "mouthUpperUpLeft": 0.15,
                     "mouthUpperUpRight": 0.15},
    "teeth": {"jawOpen": 0.12, "mouthStretchLeft": 0.2, "mouthStretchRight": 0.2,
              "mouthSmileLeft": 0.1, "mouthSmileRight": 0.1},
    "tongue": {"jawOpen": 0.16, "mouthLowerDownLeft": 0.1, "mouthLowerDownRight": 0.1},
    "back": {"jawOpen": 0.2},
    "rest": {},
}  # fmt: skip
CHANNELS = tuple(sorted({name for shape in SHAPES.values() for name in shape}))
# espeak-ng mnemonics -> shape; longest prefix first (e.g. "tS" before "t"). English's,
# plus Swedish's own (espeak-ng phsource/ph_swedish): the rounded front and central vowels
# y: y (y), Y: (ø), u- (ʉ), 8 (ɵ), the "sj" sound sx, and R. (None of them occurs in
# the English demo, whose curves stay as they were.)
PHONEME_CLASSES: tuple[tuple[str, str], ...] = tuple(sorted(
    [(p, "closed") for p in ("p", "b", "m")]
    + [(p, "labiodental") for p in ("f", "v")]
    + [(p, "rounded") for p in ("u:", "U", "w", "oU", "o@", "u@", "W", "y", "Y", "u-", "8")]
    + [(p, "round_open") for p in ("O:", "O", "0", "aU", "OI", "o")]
    + [(p, "spread") for p in ("i:", "i", "I", "j", "eI", "e@", "I@", "i@")]
    + [(p, "mid") for p in ("E", "e", "3:", "3")]
    + [(p, "open") for p in ("a", "A:", "A", "aI", "a#", "V", "&")]
    + [(p, "schwa") for p in ("@",)]
    + [(p, "postalveolar") for p in ("S", "Z", "tS", "dZ", "r", "sx")]
    + [(p, "teeth") for p in ("s", "z", "T", "D")]
    + [(p, "tongue") for p in ("t", "d", "n", "l", "N", "R")]
    + [(p, "back") for p in ("k", "g", "h", "x")]
    + [(p, "rest") for p in ("_",)],
    key=lambda pair: -len(pair[0]),
))  # fmt: skip


def shape_of(phoneme: str) -> str:
    name = phoneme.strip().lstrip("',")
    for prefix, shape in PHONEME_CLASSES:
        if name.startswith(prefix):
            return shape
    return "back"  # unknown sounds: a neutral, slightly open mouth


# -- espeak-ng ---------------------------------------------------------------------------
class _EventId(ctypes.Union):
    _fields_ = [("number", ctypes.c_int), ("name", ctypes.c_char_p),
                ("string", ctypes.c_char * 8)]  # fmt: skip


class _Event(ctypes.Structure):  # espeak_EVENT of speak_lib.h
    _fields_ = [("type", ctypes.c_int), ("unique_identifier", ctypes.c_uint),
                ("text_position", ctypes.c_int), ("length", ctypes.c_int),
                ("audio_position", ctypes.c_int), ("sample", ctypes.c_int),
                ("user_data", ctypes.c_void_p), ("id", _EventId)]  # fmt: skip


class _VoiceSelector(ctypes.Structure):  # espeak_VOICE of speak_lib.h
    _fields_ = [("name", ctypes.c_char_p), ("languages", ctypes.c_char_p),
                ("identifier", ctypes.c_char_p), ("gender", ctypes.c_ubyte),
                ("age", ctypes.c_ubyte), ("variant", ctypes.c_ubyte), ("xx1", ctypes.c_ubyte),
                ("score", ctypes.c_int), ("spare", ctypes.c_void_p)]  # fmt: skip


_CALLBACK = ctypes.CFUNCTYPE(
    ctypes.c_int, ctypes.POINTER(ctypes.c_short), ctypes.c_int, ctypes.POINTER(_Event)
)
_SYNCHRONOUS, _PHONEME_EVENTS, _DONT_EXIT = 2, 0x0001, 0x8000
_EVENT_END_OF_LIST, _EVENT_PHONEME = 0, 7
_PARAMETERS = {"speed": 1, "amplitude": 2, "pitch": 3, "word_gap": 7}
_UTF8 = 1


@dataclass(frozen=True, slots=True)
class Speech:
    samples: Samples
    rate: int
    phonemes: tuple[tuple[int, str], ...]  # (start sample, espeak mnemonic); may be empty


class EspeakLibrary:
    """espeak-ng through its C library: audio plus phoneme events with sample positions."""

    def __init__(self) -> None:
        self._lib = ctypes.CDLL("libespeak-ng.so.1")
        self.rate = int(self._lib.espeak_Initialize(_SYNCHRONOUS, 0, None,
                                                    _PHONEME_EVENTS | _DONT_EXIT))  # fmt: skip
        if self.rate <= 0:
            raise OSError("espeak_Initialize failed")
        self._chunks: list[Samples] = []
        self._phonemes: list[tuple[int, str]] = []
        self._lib.espeak_GetCurrentVoice.restype = ctypes.POINTER(_VoiceSelector)
        self._callback = _CALLBACK(self._receive)  # keep a reference: C holds the pointer
        self._lib.espeak_SetSynthCallback(self._callback)

    def _receive(self, wav: Any, count: int, events: Any) -> int:
        """espeak's synth callback: a chunk of samples and a list of events."""
        if count > 0:
            self._chunks.append(np.ctypeslib.as_array(wav, shape=(count,)).copy())
        i = 0
        while events[i].type != _EVENT_END_OF_LIST:
            if events[i].type == _EVENT_PHONEME:
                name = events[i].id.string.decode("ascii", errors="replace")
                self._phonemes.append((int(events[i].sample), name))
            i += 1
        return 0

    def _select(self, name: str) -> None:
        """A voice by file name (``en-gb-x-rp+m3``) or by language (``en-gb+f2``). The
        espeak-ng program drops the ``+variant`` of a language; here it is kept, by
        selecting the language's voice file and then that file with the variant."""
        if self._lib.espeak_SetVoiceByName(name.encode()) == 0:
            return
        language, _, variant = name.partition("+")
        wanted = _VoiceSelector(languages=language.encode())
        if self._lib.espeak_SetVoiceByProperties(ctypes.byref(wanted)) != 0:
            raise ValueError(f"espeak-ng has no voice {name!r}")
        if variant:
            current = self._lib.espeak_GetCurrentVoice().contents
            file_name = current.identifier.decode().rsplit("/", 1)[-1]
            if self._lib.espeak_SetVoiceByName(f"{file_name}+{variant}".encode()) != 0:
                raise ValueError(f"espeak-ng has no variant {variant!r} for {name!r}")

    def speak(self, text: str, voice: Mapping[str, object]) -> Speech:
        self._select(str(voice.get("espeak_voice", "en")))
        for key, parameter in _PARAMETERS.items():
            if key in voice:
                self._lib.espeak_SetParameter(parameter, int(str(voice[key])), 0)
        self._chunks, self._phonemes = [], []
        data = text.encode() + b"\0"
        self._lib.espeak_Synth(data, len(data), 0, 0, 0, _UTF8, None, None)
        self._lib.espeak_Synchronize()
        samples = np.concatenate(self._chunks) if self._chunks else np.zeros(1, np.int16)
        return Speech(samples.astype(np.int16), self.rate, tuple(self._phonemes))


class EspeakCommand:
    """Fallback: the espeak-ng program (audio only; the curves follow the envelope)."""

    def speak(self, text: str, voice: Mapping[str, object]) -> Speech:
        flags = {"speed": "-s", "amplitude": "-a", "pitch": "-p", "word_gap": "-g"}
        args = ["espeak-ng", "--stdout", "-v", str(voice.get("espeak_voice", "en"))]
        args += [item for key, flag in flags.items() if key in voice
                 for item in (flag, str(voice[key]))]  # fmt: skip
        wav = subprocess.run([*args, text], check=True, capture_output=True).stdout
        samples, rate = soundfile.read(io.BytesIO(wav), dtype="int16")
        return Speech(np.asarray(samples, dtype=np.int16), int(rate), ())


# -- lip-sync ----------------------------------------------------------------------------
def envelope(samples: Samples, rate: int, n: int) -> Floats:
    """RMS loudness per 10 ms step, 0..1 (normalised by the 95th percentile)."""
    hop = rate // CURVE_RATE
    audio = samples.astype(np.float64) / 32768.0
    padded = np.pad(audio, (0, max(0, n * hop - len(audio))))[: n * hop]
    rms = np.sqrt(np.mean(padded.reshape(n, hop) ** 2, axis=1))
    rms = gaussian_filter1d(rms, 1.5)
    top = float(np.percentile(rms, 95)) or 1.0
    loudness: Floats = np.clip(rms / top, 0.0, 1.0)
    return loudness


def lipsync_curves(speech: Speech, lead: float = 0.0) -> tuple[Floats, dict[str, Floats]]:
    """Times (30 Hz) and per-channel mouth curves for one utterance whose audio file
    starts ``lead`` seconds before the speech (the MP3 padding)."""
    pad = round(lead * speech.rate)
    samples = np.concatenate([np.zeros(pad, dtype=np.int16), speech.samples])
    phonemes = tuple((start + pad, name) for start, name in speech.phonemes)
    speech = Speech(samples, speech.rate, phonemes)
    n = int(np.ceil(len(speech.samples) / speech.rate * CURVE_RATE)) + 1
    loud = envelope(speech.samples, speech.rate, n)
    targets = {name: np.zeros(n) for name in CHANNELS}
    if speech.phonemes:
        starts = [int(s * CURVE_RATE / speech.rate) for s, _ in speech.phonemes] + [n]
        spans = itertools.pairwise(starts)
        for (start, end), (_, phoneme) in zip(spans, speech.phonemes, strict=True):
            for name, value in SHAPES[shape_of(phoneme)].items():
                targets[name][start : max(end, start + 1)] = value
    else:
        targets["jawOpen"][:] = 0.45
        targets["mouthLowerDownLeft"][:] = targets["mouthLowerDownRight"][:] = 0.2
    gate = np.clip(loud * 1.6, 0.0, 1.0)  # silence closes the mouth whatever the phoneme
    curves: dict[str, Floats] = {}
    for name, target in targets.items():
        smooth = gaussian_filter1d(target, 3.0)  # ~30 ms: neighbouring shapes blend
        curves[name] = smooth * (0.55 + 0.45 * loud if name == "jawOpen" else gate)
    curves["jawOpen"] *= gate
    step = CURVE_RATE // LIPSYNC_RATE if CURVE_RATE % LIPSYNC_RATE == 0 else None
    times = np.arange(0, n / CURVE_RATE, 1 / LIPSYNC_RATE)
    grid = np.arange(n) / CURVE_RATE
    sampled = {k: (v[::step] if step else np.interp(times, grid, v)) for k, v in curves.items()}
    length = min(len(times), *(len(v) for v in sampled.values()))
    return times[:length], {k: np.clip(v[:length], 0, 1) for k, v in sampled.items()}


def _cell(value: float) -> str:
    text = f"{value:.3f}".rstrip("0").rstrip(".")
    return text or "0"


def write_lipsync(path: Path, times: Floats, curves: Mapping[str, Floats]) -> None:
    names = [name for name in CHANNELS if np.any(curves[name] > 0.0005)]
    lines = [",".join(["time", *names])]
    lines += [",".join([f"{t:.3f}", *(_cell(curves[name][i]) for name in names)])
              for i, t in enumerate(times)]  # fmt: skip
    path.write_text("\n".join(lines) + "\n", encoding="utf-8")


def write_mp3(path: Path, speech: Speech, quality: float) -> None:
    audio = speech.samples.astype(np.float32) / 32768.0
    peak = float(np.abs(audio).max()) or 1.0
    audio = audio * (0.89 / peak)  # -1 dBFS: the four voices play equally loud
    if speech.rate != MP3_RATE:  # 16 kHz keeps a 16 kbit/s MP3 clear enough for speech
        audio = resample_poly(audio, MP3_RATE, speech.rate).astype(np.float32)
    soundfile.write(path, audio, MP3_RATE, format="MP3", bitrate_mode="CONSTANT",
                    compression_level=quality)  # fmt: skip


def mp3_delay(quality: float) -> float:
    """Seconds of encoder padding a decoder plays before the first sample (libsndfile's
    MP3s carry no gapless tag, so browsers and the WAV transcode both play it): the
    lip-sync curves are shifted by it. Measured with a click, not assumed."""
    click = np.zeros(MP3_RATE, dtype=np.float32)
    click[MP3_RATE // 2 : MP3_RATE // 2 + 400] = 0.5
    with tempfile.TemporaryDirectory() as folder:
        path = Path(folder) / "click.mp3"
        soundfile.write(path, click, MP3_RATE, format="MP3", bitrate_mode="CONSTANT",
                        compression_level=quality)  # fmt: skip
        decoded, _rate = soundfile.read(path, dtype="float32")
    onset = int(np.flatnonzero(np.abs(decoded) > 0.1)[0])
    return max(0.0, (onset - MP3_RATE // 2) / MP3_RATE)


# -- catalogue ---------------------------------------------------------------------------
def fingerprint(text: str, voice: Mapping[str, object], quality: float) -> str:
    blob = json.dumps([text, dict(voice), quality, MP3_RATE, sorted(SHAPES.items())],
                      sort_keys=True)  # fmt: skip
    return hashlib.sha256(blob.encode()).hexdigest()[:16]


def synthesize_actor(
    catalogue: Catalogue,
    engine: EspeakLibrary | EspeakCommand,
    *,
    force: bool,
    quality: float,
    lead: float,
) -> tuple[int, int]:
    """(synthesised, up to date) prompt counts; fills the manifest's two columns."""
    actor_dir = catalogue.directory
    voice = dict(catalogue.profile.voice)
    for folder in ("audio", "lipsync"):
        (actor_dir / folder).mkdir(exist_ok=True)
    stamp_path = actor_dir / "audio" / STAMP_NAME
    stamps: dict[str, str] = json.loads(stamp_path.read_text()) if stamp_path.exists() else {}
    done = fresh = 0
    assets: dict[str, tuple[str, str]] = {}
    for prompt in catalogue.prompts:
        audio, lipsync = f"audio/{prompt.id}.mp3", f"lipsync/{prompt.id}.csv"
        assets[prompt.id] = (audio, lipsync)
        stamp = fingerprint(prompt.text, voice, quality)
        present = (actor_dir / audio).is_file() and (actor_dir / lipsync).is_file()
        if present and stamps.get(prompt.id) == stamp and not force:
            fresh += 1
            continue
        speech = engine.speak(prompt.text, voice)
        write_mp3(actor_dir / audio, speech, quality)
        times, curves = lipsync_curves(speech, lead)
        write_lipsync(actor_dir / lipsync, times, curves)
        stamps[prompt.id] = stamp
        done += 1
    stamp_path.write_text(json.dumps(stamps, indent=0, sort_keys=True) + "\n")
    set_manifest_assets(actor_dir / "manifest.csv", assets)
    return done, fresh


def make_engine() -> EspeakLibrary | EspeakCommand:
    try:
        return EspeakLibrary()
    except OSError:
        if shutil.which("espeak-ng") is None:
            sys.exit("espeak-ng is not installed (Debian: apt-get install espeak-ng)")
        print("libespeak-ng not loadable: lip-sync from the audio envelope only")
        return EspeakCommand()


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--root", type=Path, default=ROOT / "prompts")
    parser.add_argument("--actor", action="append", help="only these actors (repeatable)")
    parser.add_argument("--force", action="store_true", help="synthesise everything again")
    parser.add_argument("--bitrate-quality", type=float, default=0.93,
                        help="libsndfile MP3 compression level < 1 (0.93: 16 kbit/s)")  # fmt: skip
    args = parser.parse_args(argv)
    engine = make_engine()
    lead = mp3_delay(args.bitrate_quality)
    print(f"MP3 padding: lip-sync curves start {lead * 1000:.0f} ms into the audio")
    for actor_dir in actor_directories(args.root):
        if args.actor and actor_dir.name not in args.actor:
            continue
        catalogue = load_catalogue(actor_dir)
        done, fresh = synthesize_actor(catalogue, engine, force=args.force,
                                       quality=args.bitrate_quality, lead=lead)  # fmt: skip
        print(f"{actor_dir.name}: {done} synthesised, {fresh} up to date")
    return 0


if __name__ == "__main__":
    sys.exit(main())
