"""``chameleons prompts import`` with takes written in the documented Live Link CSV format
(protocols.md 2b): 63 columns by name, 60 fps timecodes, 30/60 Hz rows."""

from __future__ import annotations

import csv
import random
import wave
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
import soundfile
from click.testing import CliRunner

from chameleons.cli.main import cli
from chameleons.prompts.importer import (
    ImportOptions,
    TakeImportError,
    import_batch,
    import_natural,
    import_take,
)
from chameleons.worker.behaviours.clips import load_clip
from chameleons.worker.frames import BLENDSHAPE_INDEX, BLENDSHAPE_NAMES, EYE_NAMES, HEAD_NAMES
from chameleons.worker.lipsync import load_lipsync

RATE = 16000
# protocols.md 2b: the CSV lists these in a different order from the UDP packet.
CSV_SWAPS = {"jawLeft": "jawRight", "jawRight": "jawLeft", "mouthLeft": "mouthRight",
             "mouthRight": "mouthLeft"}  # fmt: skip
MANIFEST = (
    "id,stage,group,text,task,item,other_item,robot_name,audio,lipsync,notes\n"
    "hello,intro,hello,Hello there.,,,,Nova,,,keep me\n"
    "bye,closing,bye,Goodbye.,,,,,,,\n"
    "ack,acknowledgement,ack,Okay.,,,,,,,\n"
)


def jaw(t: float) -> float:
    """The take's jawOpen: a ramp from 0 at 1.0 s to 1 at 2.0 s (while the tone plays)."""
    return float(np.clip(t - 1.0, 0.0, 1.0))


def timecode(t: float) -> str:
    """``HH:MM:SS:FF.fff`` on a 60 fps base."""
    millis = round(t * 60 * 1000)  # in thousandths of a frame
    whole, fraction = divmod(millis, 1000)
    seconds, ff = divmod(whole, 60)
    hours, rest = divmod(seconds, 3600)
    return f"{hours:02d}:{rest // 60:02d}:{rest % 60:02d}:{ff:02d}.{fraction:03d}"


def csv_columns() -> list[str]:
    names = [CSV_SWAPS.get(n, n) for n in BLENDSHAPE_NAMES]
    return [n[0].upper() + n[1:] for n in names]


def write_take(
    path: Path, seconds: float = 3.0, *, step: int = 1, shuffle: bool = False,
    start: float = 3600.0 * 10 + 0.5, row_hook: Callable[[int, list[str]], None] | None = None,
) -> Path:  # fmt: skip
    """A take at 60 fps timecodes advancing ``step`` frames a row (2 = 30 Hz)."""
    shapes = csv_columns()
    if shuffle:
        random.Random(7).shuffle(shapes)
    header = ["Timecode", "BlendShapeCount", *shapes, *HEAD_NAMES, *EYE_NAMES]
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("w", newline="") as handle:
        writer = csv.writer(handle)
        writer.writerow(header)
        for k in range(0, int(seconds * 60) + 1, step):
            t = k / 60
            values = {"JawOpen": jaw(t), "BrowInnerUp": 0.3, "EyeBlinkLeft": 0.5 * (k % 2)}
            row = [timecode(start + t), "61"]
            row += [f"{values.get(name, 0.0):.4f}" for name in shapes]
            row += ["0.3141593", "-0.1570796", "0", "0", "0", "0", "0", "0", "0"]  # radians
            if row_hook:
                row_hook(k, row)
            writer.writerow(row)
    return path


def write_wav(path: Path, seconds: float = 3.0, speech: tuple[float, float] = (1.0, 2.0)) -> Path:
    t = np.arange(int(seconds * RATE)) / RATE
    tone = 0.5 * np.sin(2 * np.pi * 220 * t) * ((t >= speech[0]) & (t < speech[1]))
    tone += 0.0005 * np.random.default_rng(1).standard_normal(len(t))  # room noise
    path.parent.mkdir(parents=True, exist_ok=True)
    with wave.open(str(path), "wb") as out:
        out.setnchannels(1)
        out.setsampwidth(2)
        out.setframerate(RATE)
        out.writeframes((tone * 32767).astype("<i2").tobytes())
    return path


@pytest.fixture
def actor(tmp_path: Path) -> Path:
    actor_dir = tmp_path / "prompts" / "m9"
    actor_dir.mkdir(parents=True)
    (actor_dir / "manifest.csv").write_text(MANIFEST)
    return actor_dir


@pytest.fixture
def take(tmp_path: Path) -> Path:
    write_wav(tmp_path / "takes" / "hello.wav")
    return write_take(tmp_path / "takes" / "hello.csv")


def manifest_rows(actor_dir: Path) -> dict[str, dict[str, str]]:
    with (actor_dir / "manifest.csv").open() as handle:
        return {row["id"]: row for row in csv.DictReader(handle)}


def assets(actor_dir: Path) -> list[str]:
    return sorted(str(p.relative_to(actor_dir)) for p in actor_dir.rglob("*") if p.is_file())


def test_timecodes_are_written_in_the_documented_form() -> None:
    assert timecode(36000.5) == "10:00:00:30.000"
    assert timecode(1 + 1 / 60 + 0.25 / 60) == "00:00:01:01.250"


def test_a_take_becomes_trimmed_audio_shifted_lipsync_and_a_natural_recording(
    actor: Path, take: Path
) -> None:
    result = import_take(take, actor, "hello")
    assert result.trimmed_start == pytest.approx(0.9, abs=0.03)  # 1.0 s of silence - pad
    assert result.duration == pytest.approx(1.2, abs=0.05)
    assert result.frame_rate == pytest.approx(60)
    audio, rate = soundfile.read(actor / result.audio)
    assert rate == RATE
    assert len(audio) / rate == pytest.approx(result.duration, abs=0.06)  # MP3 padding
    curves = load_lipsync(actor / result.lipsync)
    jaw_column = curves.values[:, curves.channels.index("jawOpen")]
    for u in (0.05, 0.3, 0.6, 1.0):  # the lip-sync clock starts with the trimmed audio
        expected = jaw(u + result.trimmed_start)
        assert np.interp(u, curves.times, jaw_column) == pytest.approx(expected, abs=0.02)
    assert "browInnerUp" not in curves.channels  # only mouth and jaw
    clip = load_clip(actor / result.natural)  # the natural behaviour's own loader
    assert clip.duration == pytest.approx(result.duration, abs=0.02)
    assert np.all(clip.vectors[:, BLENDSHAPE_INDEX["jawOpen"]] == 0)  # lip-sync owns it
    assert clip.vectors[5, BLENDSHAPE_INDEX["browInnerUp"]] == pytest.approx(0.3)
    assert clip.vectors[5, 52:54].tolist() == pytest.approx([18.0, -9.0])  # degrees
    rows = manifest_rows(actor)
    assert (rows["hello"]["audio"], rows["hello"]["lipsync"]) == (
        "audio/hello.mp3", "lipsync/hello.csv",
    )  # fmt: skip
    assert rows["hello"]["notes"] == "keep me"  # other cells untouched
    assert rows["bye"]["audio"] == ""
    assert assets(actor) == ["audio/hello.mp3", "lipsync/hello.csv", "manifest.csv",
                             "natural/hello.npz"]  # fmt: skip


def lipsync_of(actor: Path, prompt_id: str) -> np.ndarray:
    curves = load_lipsync(actor / f"lipsync/{prompt_id}.csv")
    return np.asarray(curves.values[:, curves.channels.index("jawOpen")])


def test_column_order_and_30_hz_rows_give_the_same_curves(actor: Path, tmp_path: Path) -> None:
    for name, step, shuffle in (("hello", 1, False), ("bye", 1, True), ("ack", 2, False)):
        write_wav(tmp_path / f"{name}.wav")
        write_take(tmp_path / f"{name}.csv", step=step, shuffle=shuffle)
        import_take(tmp_path / f"{name}.csv", actor, name)
    reference = lipsync_of(actor, "hello")
    assert np.array_equal(lipsync_of(actor, "bye"), reference)
    assert np.allclose(lipsync_of(actor, "ack"), reference, atol=0.02)


def test_a_take_folder_and_wav_audio_output(actor: Path, tmp_path: Path) -> None:
    folder = tmp_path / "Take_0042"
    write_take(folder / "Take_0042_iPhone.csv")
    write_wav(folder / "Take_0042_iPhone.wav")
    result = import_take(folder, actor, "bye", ImportOptions(audio_format="wav"))
    assert soundfile.info(actor / result.audio).subtype == "PCM_16"


def test_the_audio_offset_shifts_the_curves(actor: Path, tmp_path: Path) -> None:
    """Audio that started 0.5 s after the CSV: the speech sits 0.5 s later in the take."""
    write_take(tmp_path / "late.csv", seconds=3.5)
    write_wav(tmp_path / "late.wav", speech=(0.5, 1.5))
    result = import_take(tmp_path / "late.csv", actor, "hello", ImportOptions(audio_offset=0.5))
    assert result.trimmed_start == pytest.approx(0.4, abs=0.03)
    assert lipsync_of(actor, "hello")[36] == pytest.approx(jaw(0.6 + 0.9), abs=0.02)


def broken_row(k: int, row: list[str]) -> None:
    if k == 90:
        row[5] = "oops"


@pytest.mark.parametrize(
    ("make", "message"),
    [
        (lambda d: write_take(d / "t.csv", row_hook=broken_row), "is not a number"),
        (lambda d: write_take(d / "t.csv", seconds=1.5), "does not cover the speech"),
        (lambda d: (d / "t.csv").write_text("Timecode,BlendShapeCount\n"), "missing blendshape"),
    ],
)
def test_a_broken_take_is_reported_and_nothing_is_written(
    actor: Path, tmp_path: Path, make: Callable[[Path], object], message: str
) -> None:
    write_wav(tmp_path / "t.wav")
    make(tmp_path)
    before = (actor / "manifest.csv").read_text()
    with pytest.raises(TakeImportError, match=message) as caught:
        import_take(tmp_path / "t.csv", actor, "hello")
    assert "t.csv" in str(caught.value)
    assert assets(actor) == ["manifest.csv"]  # no half-import, no staging leftovers
    assert (actor / "manifest.csv").read_text() == before


@pytest.mark.parametrize(
    ("audio", "message"),
    [(b"RIFF garbage", "cannot read audio"), (None, "no WAV beside the take")],
)
def test_bad_or_missing_audio_is_reported(
    actor: Path, tmp_path: Path, audio: bytes | None, message: str
) -> None:
    write_take(tmp_path / "t.csv")
    if audio is not None:
        (tmp_path / "t.wav").write_bytes(audio)
    with pytest.raises(TakeImportError, match=message):
        import_take(tmp_path / "t.csv", actor, "hello")
    assert assets(actor) == ["manifest.csv"]


def test_silent_audio_and_unknown_prompts_are_reported(actor: Path, tmp_path: Path) -> None:
    write_take(tmp_path / "t.csv")
    write_wav(tmp_path / "t.wav", speech=(0.0, 0.0))
    with pytest.raises(TakeImportError, match="silent"):
        import_take(tmp_path / "t.csv", actor, "hello")
    with pytest.raises(TakeImportError, match="no prompt with id 'nope'"):
        import_take(tmp_path / "t.csv", actor, "nope")


def test_a_take_becomes_a_natural_recording_with_the_whole_face(actor: Path, take: Path) -> None:
    natural = import_natural(take, actor, "idle_1")
    assert natural.notes == ()  # the head moved in this take
    clip = load_clip(natural.path)
    assert clip.duration == pytest.approx(3.0)
    assert clip.vectors[-1, BLENDSHAPE_INDEX["jawOpen"]] == pytest.approx(1.0)
    with pytest.raises(TakeImportError, match="may only use"):
        import_natural(take, actor, "../escape")


def write_batch(tmp_path: Path) -> Path:
    for name in ("good", "broken"):
        write_wav(tmp_path / "takes" / f"{name}.wav")
    write_take(tmp_path / "takes" / "good.csv")
    write_take(tmp_path / "takes" / "broken.csv", row_hook=broken_row)
    batch = tmp_path / "takes" / "batch.csv"
    batch.write_text("take,prompt_id\ngood.csv,hello\nbroken.csv,bye\ngood.csv,hello\n")
    return batch


def test_batch_imports_what_it_can_and_reports_each_problem(actor: Path, tmp_path: Path) -> None:
    outcomes = import_batch(write_batch(tmp_path), actor)
    assert [o.result is not None for o in outcomes] == [True, False, False]
    assert "batch.csv:3" in str(outcomes[1].problem)
    assert "broken.csv" in str(outcomes[1].problem)
    assert "also on line 2" in str(outcomes[2].problem)
    rows = manifest_rows(actor)
    assert (rows["hello"]["audio"], rows["bye"]["audio"]) == ("audio/hello.mp3", "")


def test_cli_single_batch_and_errors(actor: Path, tmp_path: Path, take: Path) -> None:
    runner = CliRunner()
    one = runner.invoke(cli, ["prompts", "import", str(actor), str(take), "--prompt-id", "ack"])
    assert one.exit_code == 0, one.output
    assert "ack: 1.20 s" in one.output
    batch = runner.invoke(cli, ["prompts", "import", str(actor), "--batch",
                                str(write_batch(tmp_path))])  # fmt: skip
    assert batch.exit_code == 1
    assert "1 imported, 2 failed" in batch.output
    both = runner.invoke(cli, ["prompts", "import", str(actor), str(take), "--prompt-id", "a",
                               "--natural", "b"])  # fmt: skip
    assert both.exit_code == 2
    assert "exactly one of" in both.output
    bad = runner.invoke(cli, ["prompts", "import", str(actor), str(take), "--prompt-id", "nope"])
    assert bad.exit_code == 1
    assert "not imported" in bad.output


def head_off(_k: int, row: list[str]) -> None:
    row[-9:-6] = ["0", "0", "0"]  # HeadYaw, HeadPitch, HeadRoll: streaming was off


def test_a_take_without_head_rotation_is_noted_where_it_is_imported(
    actor: Path, tmp_path: Path
) -> None:
    write_wav(tmp_path / "takes" / "still.wav")
    still = write_take(tmp_path / "takes" / "still.csv", row_hook=head_off)
    note = "note: head streaming was off in this take (HeadYaw, HeadPitch, HeadRoll all zero)"
    runner = CliRunner()
    one = runner.invoke(cli, ["prompts", "import", str(actor), str(still), "--prompt-id", "ack"])
    assert one.exit_code == 0, one.output
    assert note in one.output
    natural = runner.invoke(cli, ["prompts", "import", str(actor), str(still), "--natural", "n1"])
    assert natural.exit_code == 0, natural.output
    assert note in natural.output
    batch_file = tmp_path / "takes" / "batch.csv"
    batch_file.write_text("take,prompt_id\nstill.csv,hello\n")
    batch = runner.invoke(cli, ["prompts", "import", str(actor), "--batch", str(batch_file)])
    assert batch.exit_code == 0, batch.output
    assert "note: hello: head streaming was off" in batch.output
    moving = runner.invoke(cli, ["prompts", "import", str(actor), str(write_take(
        tmp_path / "takes" / "moving.csv")), "--natural", "n2"])  # fmt: skip
    assert "head streaming" not in moving.output
