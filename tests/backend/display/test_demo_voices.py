"""The demo voices: the synthesiser's lip-sync derivation, and the committed assets the
display plays (every demo prompt has audio and curves, compact, in step with each other)."""

from __future__ import annotations

import importlib.util
import random
import sys
from pathlib import Path
from types import ModuleType

import numpy as np
import pytest
import soundfile

from chameleons.prompts import Catalogue, load_catalogues
from chameleons.worker.lipsync import LIPSYNC_NAMES, load_lipsync

ROOT = Path(__file__).resolve().parents[3]
PROMPTS = ROOT / "prompts"
MAX_DEMO_AUDIO_BYTES = 20 * 1024 * 1024


@pytest.fixture(scope="module")
def synth() -> ModuleType:
    path = ROOT / "scripts" / "synthesize_voices.py"
    spec = importlib.util.spec_from_file_location("synthesize_voices", path)
    assert spec is not None
    assert spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


@pytest.fixture(scope="module")
def espeak(synth: ModuleType) -> object:
    try:
        return synth.EspeakLibrary()
    except OSError:
        pytest.skip("libespeak-ng is not installed")


def channel(curves: dict[str, np.ndarray], times: np.ndarray, name: str, t: float) -> float:
    return float(np.interp(t, times, curves[name]))


def test_phonemes_shape_the_mouth(synth: ModuleType, espeak: object) -> None:
    speech = espeak.speak("Bob saw you.", {"espeak_voice": "en-us"})  # type: ignore[attr-defined]
    ends = [*speech.phonemes[1:], (len(speech.samples), "")]
    spans = [(name, start / speech.rate, end / speech.rate)
             for (start, name), (end, _) in zip(speech.phonemes, ends, strict=True)]  # fmt: skip
    middles = {name: (a + b) / 2 for name, a, b in reversed(spans)}  # first occurrence wins
    assert {"b", "O:", "u:"} <= set(middles)
    times, curves = synth.lipsync_curves(speech)
    assert times[1] - times[0] == pytest.approx(1 / 30)
    assert len(times) / 30 == pytest.approx(len(speech.samples) / speech.rate, abs=0.1)
    assert all(v.min() >= 0 and v.max() <= 1 for v in curves.values())
    vowel = middles["O:"]
    assert channel(curves, times, "jawOpen", vowel) > 0.15
    assert channel(curves, times, "mouthFunnel", vowel) > 0.15  # "saw": rounded and open
    closure = middles["b"]
    assert channel(curves, times, "mouthPressLeft", closure) > 0.1  # "Bob": lips meet
    assert channel(curves, times, "jawOpen", closure) < channel(curves, times, "jawOpen", vowel)
    assert channel(curves, times, "jawOpen", times[-1]) < 0.05  # silent at the end


def test_curves_wait_for_the_mp3_padding(synth: ModuleType, espeak: object) -> None:
    lead = synth.mp3_delay(0.93)
    assert 0.01 < lead < 0.2
    speech = espeak.speak("Ma.", {"espeak_voice": "en-us"})  # type: ignore[attr-defined]
    plain_times, plain = synth.lipsync_curves(speech)
    times, shifted = synth.lipsync_curves(speech, lead)
    peak = plain_times[np.argmax(plain["jawOpen"])]
    assert times[np.argmax(shifted["jawOpen"])] == pytest.approx(peak + lead, abs=0.04)


def test_the_language_variant_is_kept(espeak: object) -> None:
    """``en-gb+f2`` is a female voice, not British English's default male one."""
    plain = espeak.speak("Hello there.", {"espeak_voice": "en-gb"})  # type: ignore[attr-defined]
    female = espeak.speak("Hello there.", {"espeak_voice": "en-gb+f2"})  # type: ignore[attr-defined]
    assert not np.array_equal(plain.samples[:4000], female.samples[:4000])


def demo_catalogues() -> dict[str, Catalogue]:
    catalogues = load_catalogues(PROMPTS)  # also checks every listed file exists
    if not all(p.audio for c in catalogues.values() for p in c.prompts):
        pytest.skip("the demo voices are not generated yet")
    return catalogues


def test_every_demo_prompt_speaks_compactly() -> None:
    catalogues = demo_catalogues()
    assert len(catalogues) == 4
    for catalogue in catalogues.values():
        assert all(p.lipsync for p in catalogue.prompts)
    total = sum(path.stat().st_size for path in PROMPTS.glob("*/audio/*.mp3"))
    assert total < MAX_DEMO_AUDIO_BYTES


def test_demo_curves_last_as_long_as_their_audio() -> None:
    catalogues = demo_catalogues()
    rng = random.Random(3)
    for actor, catalogue in catalogues.items():
        for prompt in rng.sample(list(catalogue.prompts), 3):
            audio = soundfile.info(PROMPTS / actor / str(prompt.audio))
            curves = load_lipsync(PROMPTS / actor / str(prompt.lipsync))
            assert audio.samplerate == 16000
            assert curves.duration == pytest.approx(audio.duration, abs=0.15)
            assert set(curves.channels) <= set(LIPSYNC_NAMES)
            jaw = curves.values[:, LIPSYNC_NAMES.index("jawOpen")]
            assert jaw.max() > 0.2  # the mouth moves
