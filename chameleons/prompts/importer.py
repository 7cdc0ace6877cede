"""Live Link Face takes -> prompt assets of an actor (``chameleons prompts import``).

A take is a Live Link Face CSV (protocols.md 2b, read by :mod:`chameleons.worker.takes`:
columns by header name, time from the 60 fps timecode) plus the WAV recorded with it —
given as the two files, as the CSV alone with a same-named WAV beside it, or as a take
folder holding one CSV and one WAV. The CSV's first row and the WAV's first sample are
taken to be the same moment (``audio_offset`` says by how much the audio starts later).

For a prompt ``<id>`` the import writes, in the actor folder:

- ``audio/<id>.mp3`` (or ``.wav``): the audio with leading and trailing silence trimmed
  (keeping ``pad`` seconds), mono;
- ``lipsync/<id>.csv``: the mouth and jaw curves on the trimmed audio's clock (shifted by
  the trimmed lead-in), resampled to 60 Hz — the lip-sync format of
  :mod:`chameleons.worker.lipsync`;
- ``natural/<id>.npz``: the rest of the face (mouth and jaw zeroed: lip-sync owns them
  while speaking) with head and eyes in degrees, loadable by the ``natural`` behaviour
  (``times``, ``blendshapes``, ``head``, ``eyes``; see ``behaviours/clips.py``);

and sets the ``audio``/``lipsync`` cells of the prompt's manifest row. ``import_natural``
turns a take into ``natural/<name>.npz`` alone, whole face kept, no audio needed.

Everything is written to a temporary folder first and moved into place only when the
whole take succeeded: a broken take is reported (:class:`TakeImportError`), never
half-imported.
"""

from __future__ import annotations

import csv
import os
import re
import shutil
import tempfile
from collections.abc import Iterator, Sequence
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import BLENDSHAPE_NAMES, MOUTH_JAW_INDICES
from chameleons.worker.ingest.livelink import DEFAULT_ROTATION_FACTOR
from chameleons.worker.takes import Take, TakeError, read_take

F64Array = npt.NDArray[np.float64]
LIPSYNC_RATE = 60.0
SPEECH_FLOOR = 10 ** (-50 / 20)  # RMS: a recording that never gets louder holds no speech
MANIFEST_NAME = "manifest.csv"
AUDIO_FORMATS = ("mp3", "wav")
_NAME = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_.-]*$")


class TakeImportError(ValueError):
    """Why a take was not imported; the message names the file."""


@dataclass(frozen=True, slots=True)
class ImportOptions:
    rotation_factor: float = DEFAULT_ROTATION_FACTOR
    audio_offset: float = 0.0  # seconds the audio starts after the CSV's first row
    silence_db: float = -35.0  # below the loudest 20 ms by this much counts as silence
    pad: float = 0.1  # seconds of silence kept before and after the speech
    audio_format: str = "mp3"


@dataclass(frozen=True, slots=True)
class ImportedPrompt:
    prompt_id: str
    audio: str  # relative to the actor folder, as in the manifest
    lipsync: str
    natural: str
    duration: float
    trimmed_start: float
    frame_rate: float  # of the take's rows
    notes: tuple[str, ...] = ()  # what the take lacks (e.g. head streaming was off)


@dataclass(frozen=True, slots=True)
class ImportedNatural:
    path: Path  # the natural recording written
    notes: tuple[str, ...] = ()  # what the take lacks (e.g. head streaming was off)


@dataclass(frozen=True, slots=True)
class TakeFiles:
    csv: Path
    wav: Path | None


def find_take(path: Path, wav: Path | None = None) -> TakeFiles:
    """The CSV and WAV of a take given as a CSV file or a take folder."""
    if path.is_dir():
        csvs, wavs = sorted(path.glob("*.csv")), sorted(path.glob("*.wav"))
        if len(csvs) != 1:
            raise TakeImportError(f"{path}: a take folder needs exactly one CSV, found {len(csvs)}")
        if wav is None and len(wavs) > 1:
            raise TakeImportError(f"{path}: more than one WAV; name the audio explicitly")
        return TakeFiles(csvs[0], wav or (wavs[0] if wavs else None))
    if not path.is_file():
        raise TakeImportError(f"{path}: no such take file or folder")
    beside = path.with_suffix(".wav")
    return TakeFiles(path, wav or (beside if beside.is_file() else None))


# -- audio -------------------------------------------------------------------------------
def read_audio(path: Path) -> tuple[npt.NDArray[np.float32], int]:
    import soundfile  # reads WAV (any PCM/float subtype), FLAC, Ogg, MP3

    try:
        data, rate = soundfile.read(path, dtype="float32", always_2d=True)
    except (OSError, RuntimeError) as exc:  # soundfile.LibsndfileError is a RuntimeError
        raise TakeImportError(f"{path}: cannot read audio: {exc}") from exc
    if len(data) == 0:
        raise TakeImportError(f"{path}: the audio is empty")
    mono: npt.NDArray[np.float32] = data.mean(axis=1).astype(np.float32)
    return mono, int(rate)


def speech_span(audio: npt.NDArray[np.float32], rate: int, silence_db: float) -> tuple[int, int]:
    """First and last sample (exclusive) of the non-silent part, by 20 ms RMS windows."""
    window = max(1, rate // 50)
    n = len(audio) // window
    if n == 0:
        raise TakeImportError("the audio is shorter than 20 ms")
    rms = np.sqrt(np.mean(audio[: n * window].reshape(n, window) ** 2, axis=1))
    peak = float(rms.max())
    if peak < SPEECH_FLOOR:
        raise TakeImportError("the audio is silent (nothing louder than -50 dBFS)")
    loud = np.flatnonzero(rms >= peak * 10 ** (silence_db / 20))
    return int(loud[0]) * window, min(len(audio), (int(loud[-1]) + 1) * window)


def write_audio(path: Path, audio: npt.NDArray[np.float32], rate: int, audio_format: str) -> None:
    import soundfile

    if audio_format == "mp3":  # compact, and every browser plays it
        soundfile.write(path, audio, rate, format="MP3", bitrate_mode="VARIABLE",
                        compression_level=0.6)  # fmt: skip
    else:
        soundfile.write(path, audio, rate, format="WAV", subtype="PCM_16")


# -- curves ------------------------------------------------------------------------------
def resample(take: Take, start: float, duration: float) -> tuple[F64Array, Take]:
    """The take on a uniform 60 Hz grid over [start, start + duration], re-based to 0."""
    grid = np.arange(0.0, duration + 1e-9, 1.0 / LIPSYNC_RATE)
    if len(grid) < 2:
        grid = np.array([0.0, duration if duration > 0 else 1.0 / LIPSYNC_RATE])
    source = take.times

    def interp(values: npt.NDArray[np.float32]) -> npt.NDArray[np.float32]:
        columns = [np.interp(grid + start, source, values[:, k]) for k in range(values.shape[1])]
        return np.stack(columns, axis=1).astype(np.float32)

    resampled = Take(grid, interp(take.blendshapes), interp(take.head), interp(take.eyes),
                     take.source)  # fmt: skip
    return grid, resampled


def write_lipsync(path: Path, take: Take) -> None:
    names = [BLENDSHAPE_NAMES[i] for i in MOUTH_JAW_INDICES]
    with path.open("w", newline="", encoding="utf-8") as handle:
        writer = csv.writer(handle, lineterminator="\n")
        writer.writerow(["time", *names])
        for t, row in zip(take.times, take.blendshapes[:, list(MOUTH_JAW_INDICES)], strict=True):
            writer.writerow([f"{t:.4f}", *(f"{v:.3f}" for v in row)])


def write_natural(path: Path, take: Take, *, keep_mouth: bool) -> None:
    shapes = take.blendshapes.copy()
    if not keep_mouth:
        shapes[:, list(MOUTH_JAW_INDICES)] = 0.0
    with path.open("wb") as handle:  # np.savez would append ".npz" to a str path
        np.savez_compressed(handle, times=take.times, blendshapes=shapes, head=take.head,
                            eyes=take.eyes)  # fmt: skip


def frame_rate(take: Take) -> float:
    return float(1.0 / np.median(np.diff(take.times))) if len(take) > 1 else 0.0


# -- one take ----------------------------------------------------------------------------
def import_take(
    take_path: Path, actor_dir: Path, prompt_id: str, options: ImportOptions | None = None,
    *, wav: Path | None = None,
) -> ImportedPrompt:  # fmt: skip
    """Import one take as prompt ``prompt_id``; raises :class:`TakeImportError`."""
    options = options or ImportOptions()
    _check_name(prompt_id)
    if options.audio_format not in AUDIO_FORMATS:
        raise TakeImportError(f"audio format must be one of {', '.join(AUDIO_FORMATS)}")
    manifest = actor_dir / MANIFEST_NAME
    if prompt_id not in manifest_ids(manifest):
        raise TakeImportError(f"{manifest}: no prompt with id '{prompt_id}'")
    files = find_take(take_path, wav)
    if files.wav is None:
        raise TakeImportError(f"{files.csv}: no WAV beside the take (give it with --wav)")
    take = _read_take(files.csv, options)
    audio, rate = read_audio(files.wav)
    try:
        first, last = speech_span(audio, rate, options.silence_db)
    except TakeImportError as problem:
        raise TakeImportError(f"{files.wav}: {problem}") from None
    pad = int(options.pad * rate)
    first, last = max(0, first - pad), min(len(audio), last + pad)
    start, duration = first / rate, (last - first) / rate
    face_start = start + options.audio_offset
    if face_start + duration > take.duration + 0.25 or face_start < -0.25:
        raise TakeImportError(
            f"{files.csv}: the face recording ({take.duration:.2f} s) does not cover the speech "
            f"({face_start:.2f}-{face_start + duration:.2f} s); check --audio-offset"
        )
    _grid, curves = resample(take, face_start, duration)
    result = ImportedPrompt(
        prompt_id, f"audio/{prompt_id}.{options.audio_format}", f"lipsync/{prompt_id}.csv",
        f"natural/{prompt_id}.npz", round(duration, 3), round(start, 3),
        round(frame_rate(take), 1), take.notes,
    )  # fmt: skip
    with staging(actor_dir) as stage:
        write_audio(stage / result.audio, audio[first:last], rate, options.audio_format)
        write_lipsync(stage / result.lipsync, curves)
        write_natural(stage / result.natural, curves, keep_mouth=False)
        commit(stage, actor_dir, [result.audio, result.lipsync, result.natural])
    set_manifest_assets(manifest, {prompt_id: (result.audio, result.lipsync)})
    return result


def import_natural(
    take_path: Path, actor_dir: Path, name: str, options: ImportOptions | None = None
) -> ImportedNatural:
    """A take as ``natural/<name>.npz`` for the ``natural`` behaviour (whole face kept)."""
    options = options or ImportOptions()
    _check_name(name)
    take = _read_take(find_take(take_path).csv, options)
    _grid, resampled = resample(take, 0.0, take.duration)
    relative = f"natural/{name}.npz"
    with staging(actor_dir) as stage:
        write_natural(stage / relative, resampled, keep_mouth=True)
        commit(stage, actor_dir, [relative])
    return ImportedNatural(actor_dir / relative, take.notes)


def _check_name(name: str) -> None:
    # Names become file names: keep them to the manifest's id alphabet.
    if not _NAME.match(name):
        raise TakeImportError(f"'{name}' may only use letters, digits, '_', '-', '.'")


def _read_take(path: Path, options: ImportOptions) -> Take:
    try:
        take = read_take(path, rotation_factor=options.rotation_factor)
    except TakeError as exc:
        raise TakeImportError(str(exc)) from None
    if len(take) < 2:
        raise TakeImportError(f"{path}: a take needs at least two rows")
    return take


@contextmanager
def staging(actor_dir: Path) -> Iterator[Path]:
    """A temporary folder beside the actor's files (same file system: moves are atomic)."""
    actor_dir.mkdir(parents=True, exist_ok=True)
    stage = Path(tempfile.mkdtemp(prefix=".import-", dir=actor_dir))
    try:
        for sub in ("audio", "lipsync", "natural"):
            (stage / sub).mkdir()
        yield stage
    finally:
        shutil.rmtree(stage, ignore_errors=True)


def commit(stage: Path, actor_dir: Path, relatives: Sequence[str]) -> None:
    for relative in relatives:
        (actor_dir / relative).parent.mkdir(parents=True, exist_ok=True)
        os.replace(stage / relative, actor_dir / relative)


# -- manifests ---------------------------------------------------------------------------
def manifest_ids(manifest: Path) -> set[str]:
    header, rows = _read_rows(manifest)
    names = [cell.strip().lower() for cell in header]
    if "id" not in names:
        raise TakeImportError(f"{manifest}:1: no 'id' column")
    column = names.index("id")
    return {row[column].strip() for row in rows if len(row) > column}


def set_manifest_assets(manifest: Path, assets: dict[str, tuple[str, str]]) -> None:
    """Set only the ``audio`` and ``lipsync`` cells of the given prompt ids (columns are
    added when missing); every other cell, column and row stays as it was."""
    header, rows = _read_rows(manifest)
    names = [cell.strip().lower() for cell in header]
    for column in ("audio", "lipsync"):
        if column not in names:
            header.append(column)
            names.append(column)
    id_col, audio_col, lipsync_col = (names.index(c) for c in ("id", "audio", "lipsync"))
    for row in rows:
        row.extend([""] * (len(header) - len(row)))
        prompt_id = row[id_col].strip()
        if prompt_id in assets:
            row[audio_col], row[lipsync_col] = assets[prompt_id]
    handle, temporary = tempfile.mkstemp(prefix=".manifest-", dir=manifest.parent)
    with os.fdopen(handle, "w", newline="", encoding="utf-8") as out:
        writer = csv.writer(out, lineterminator="\n")
        writer.writerow(header)
        writer.writerows(rows)
    os.replace(temporary, manifest)


def _read_rows(manifest: Path) -> tuple[list[str], list[list[str]]]:
    try:
        with manifest.open(encoding="utf-8-sig", newline="") as handle:
            records = list(csv.reader(handle, strict=True))
    except (OSError, csv.Error, UnicodeDecodeError) as exc:
        raise TakeImportError(f"{manifest}: cannot read the manifest: {exc}") from exc
    if not records:
        raise TakeImportError(f"{manifest}: empty manifest")
    return list(records[0]), [r for r in records[1:] if any(c.strip() for c in r)]


# -- batch -------------------------------------------------------------------------------
@dataclass(frozen=True, slots=True)
class BatchEntry:
    line: int
    take: Path
    prompt_id: str
    wav: Path | None = None


@dataclass(frozen=True, slots=True)
class BatchOutcome:
    entry: BatchEntry
    result: ImportedPrompt | None = None
    problem: str | None = None


def read_batch(path: Path) -> list[BatchEntry]:
    """A batch manifest: CSV with columns ``take`` and ``prompt_id`` (optional ``wav``);
    paths relative to the batch file's folder."""
    header, rows = _read_rows(path)
    names = [cell.strip().lower() for cell in header]
    missing = [c for c in ("take", "prompt_id") if c not in names]
    if missing:
        raise TakeImportError(f"{path}:1: batch manifest needs columns take, prompt_id "
                            f"(missing {', '.join(missing)})")  # fmt: skip
    base = path.parent
    entries = []
    for line, row in enumerate(rows, start=2):
        cells = dict(zip(names, (c.strip() for c in row), strict=False))
        wav = cells.get("wav")
        entries.append(BatchEntry(line, base / cells.get("take", ""), cells.get("prompt_id", ""),
                                  base / wav if wav else None))  # fmt: skip
    return entries


def import_batch(
    path: Path, actor_dir: Path, options: ImportOptions | None = None
) -> list[BatchOutcome]:
    """Import every take of a batch manifest; one outcome per entry, problems included."""
    outcomes: list[BatchOutcome] = []
    seen: dict[str, int] = {}
    for entry in read_batch(path):
        first = seen.setdefault(entry.prompt_id, entry.line)
        if not entry.prompt_id or first != entry.line:
            why = "empty prompt_id" if not entry.prompt_id else f"prompt_id also on line {first}"
            outcomes.append(BatchOutcome(entry, problem=f"{path}:{entry.line}: {why}"))
            continue
        try:
            result = import_take(entry.take, actor_dir, entry.prompt_id, options, wav=entry.wav)
        except TakeImportError as problem:
            outcomes.append(BatchOutcome(entry, problem=f"{path}:{entry.line}: {problem}"))
        else:
            outcomes.append(BatchOutcome(entry, result=result))
    return outcomes
