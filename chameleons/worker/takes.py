"""Live Link Face take CSVs (protocols.md 2b) -> :class:`Take`.

A take's header names its columns: ``Timecode, BlendShapeCount``, the 52 blendshapes in
PascalCase and ``HeadYaw .. RightEyeRoll``. The column order differs from the UDP order, so
columns are mapped by name (any spelling :func:`canonical_name` knows), never by position.
Time comes from the ``Timecode`` ``HH:MM:SS:FF.fff`` (``.fff`` a fraction of a frame),
never from the row index: rows may advance by 1 or 2 frames (60 or 30 Hz). The timecode's
frame base is the app's timecode setting, not always 60: 24, 25, 29.97, 30, 50 or 60. A
take does not name it, so it is read from the frame numbers (the smallest base above the
highest ``FF`` once the take crossed a whole second, else 60; ``;`` before the frames means
29.97 drop-frame) unless given (``fps``).
Head and eye columns use the Live Link rotation unit (radians, see
:mod:`chameleons.worker.ingest.livelink`); they are all zero unless head rotation streaming
was on in the app, which :attr:`Take.notes` reports. Missing head/eye columns read as zero;
a missing ``TongueOut`` too.
"""

from __future__ import annotations

import csv
import logging
import math
import re
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import (
    BLENDSHAPE_INDEX,
    EYE_NAMES,
    HEAD_NAMES,
    N_BLENDSHAPES,
    F32Array,
    FaceFrame,
    canonical_name,
)
from chameleons.worker.ingest.livelink import DEFAULT_ROTATION_FACTOR

log = logging.getLogger(__name__)
F64Array = npt.NDArray[np.float64]
TIMECODE_FPS = 60.0
DROP_FRAME_FPS = 30000 / 1001  # 29.97: timecode counts 30 a second, dropping numbers
TIMECODE_BASES = (24.0, 25.0, 30.0, 50.0, 60.0)
HEAD_OFF_NOTE = "head streaming was off in this take (HeadYaw, HeadPitch, HeadRoll all zero)"
_TIMECODE = re.compile(r"(\d{1,2}):(\d{2}):(\d{2})([:;.])(\d{1,3})(?:\.(\d+))?")
_DAY = 86400.0
_OPTIONAL_SHAPES = frozenset({"tongueOut"})


class TakeError(ValueError):
    """A take that cannot be read; the message names the file and, where known, the line."""


@dataclass(frozen=True, slots=True)
class Take:
    """A recorded face: ``times`` (n,) seconds from 0, strictly increasing; ``blendshapes``
    (n, 52) float32 in canonical order, 0..1; ``head`` (n, 3) yaw/pitch/roll and ``eyes``
    (n, 6) left then right yaw/pitch/roll, degrees."""

    times: F64Array
    blendshapes: F32Array
    head: F32Array
    eyes: F32Array
    source: str = ""
    notes: tuple[str, ...] = ()  # what the lab should know (e.g. head streaming was off)
    timecode_fps: float = TIMECODE_FPS

    def __post_init__(self) -> None:
        n = len(self.times)
        shapes = {"blendshapes": (n, N_BLENDSHAPES), "head": (n, 3), "eyes": (n, 6)}
        for name, shape in shapes.items():
            if getattr(self, name).shape != shape:
                raise ValueError(f"take {name} must have shape {shape}")

    def __len__(self) -> int:
        return len(self.times)

    @property
    def duration(self) -> float:
        return float(self.times[-1]) if len(self.times) else 0.0

    def frame(self, index: int, now: float = 0.0) -> FaceFrame:
        """Row ``index`` as a FaceFrame stamped ``now``."""
        return FaceFrame(
            now, now, self.blendshapes[index].copy(), self.head[index].copy(),
            self.eyes[index].copy(), self.source,
        )  # fmt: skip


def parse_timecode(text: str, fps: float = TIMECODE_FPS) -> float:
    """``HH:MM:SS:FF.fff`` -> seconds since midnight (``FF.fff`` frames at ``fps``). At 29.97
    (:data:`DROP_FRAME_FPS`) the frames are counted in SMPTE drop-frame: numbers 0 and 1 are
    skipped at every minute except each tenth."""
    hours, minutes, seconds, frames, fraction, _drop = _fields(text)
    nominal = round(fps)
    if minutes > 59 or seconds > 59 or frames >= nominal:
        raise ValueError(f"timecode {text!r} is out of range for {fps:g} fps")
    if abs(fps - DROP_FRAME_FPS) < 1e-6:
        total_minutes = 60 * hours + minutes
        number = (3600 * hours + 60 * minutes + seconds) * 30 + frames
        number -= 2 * (total_minutes - total_minutes // 10)
        return (number + fraction) / DROP_FRAME_FPS
    return hours * 3600 + minutes * 60 + seconds + (frames + fraction) / fps


def _fields(text: str) -> tuple[int, int, int, int, float, bool]:
    match = _TIMECODE.fullmatch(text.strip())
    if match is None:
        raise ValueError(f"timecode {text!r} is not HH:MM:SS:FF.fff")
    hours, minutes, seconds = (int(g) for g in match.group(1, 2, 3))
    fraction = float("0." + match.group(6)) if match.group(6) else 0.0
    return hours, minutes, seconds, int(match.group(5)), fraction, match.group(4) == ";"


def timecode_base(texts: list[str]) -> float:
    """The timecode's frame rate, from the frame numbers seen: drop-frame (``;``) is 29.97;
    a take that crosses a whole second has shown every frame number, so its base is the
    smallest standard one above the highest; a shorter take keeps the app's default, 60."""
    fields = [_fields(t) for t in texts]
    if any(f[5] for f in fields):
        return DROP_FRAME_FPS
    highest = max((f[3] for f in fields), default=0)
    if len({f[:3] for f in fields}) < 2 and highest < TIMECODE_FPS:
        return TIMECODE_FPS
    base = next((b for b in TIMECODE_BASES if highest < b), None)
    if base is None:
        raise ValueError(
            f"frame number {highest} is out of range for every timecode base (24 to 60 fps)"
        )
    return base


class _Columns:
    """Header name -> column index, by canonical name."""

    def __init__(self, header: list[str], where: str) -> None:
        self.width = len(header)
        by_name: dict[str, int] = {}
        for i, raw in enumerate(header):
            name = raw.strip()
            key = canonical_name(name) or name.lower()
            if key in by_name:
                raise TakeError(f"{where}:1: column {name!r} appears twice")
            by_name[key] = i
        if "timecode" not in by_name:
            raise TakeError(f"{where}:1: no Timecode column")
        missing = [n for n in BLENDSHAPE_INDEX if n not in by_name and n not in _OPTIONAL_SHAPES]
        if missing:
            raise TakeError(f"{where}:1: missing blendshape columns: {', '.join(missing)}")
        self.timecode = by_name["timecode"]
        self.shapes = [(BLENDSHAPE_INDEX[n], by_name[n]) for n in BLENDSHAPE_INDEX if n in by_name]
        rotations = (*HEAD_NAMES, *EYE_NAMES)
        self.rotations = [
            (j, by_name[n.lower()]) for j, n in enumerate(rotations) if n.lower() in by_name
        ]


def read_take(
    path: str | Path,
    *,
    rotation_factor: float = DEFAULT_ROTATION_FACTOR,
    fps: float | None = None,
) -> Take:
    """Read a Live Link Face take CSV; raises :class:`TakeError` naming file and line.
    ``fps`` is the timecode's frame base; None reads it from the take."""  # fmt: skip
    path = Path(path)
    try:
        with path.open(newline="", encoding="utf-8-sig") as handle:
            return _read(csv.reader(handle), str(path), rotation_factor, fps)
    except OSError as exc:
        raise TakeError(f"{path}: cannot read: {exc.strerror or exc}") from exc
    except UnicodeDecodeError as exc:
        raise TakeError(f"{path}: not UTF-8 text: {exc}") from exc
    except csv.Error as exc:
        raise TakeError(f"{path}: not a CSV file: {exc}") from exc


def _read(
    reader: csv.Reader,  # type: ignore[name-defined]
    where: str, rotation_factor: float, fps: float | None,
) -> Take:  # fmt: skip
    header = next(reader, None)
    if not header:
        raise TakeError(f"{where}:1: empty file, expected a header row")
    columns = _Columns(header, where)
    rows: list[tuple[str, list[str]]] = []
    for row in reader:
        if not any(cell.strip() for cell in row):
            continue
        line = f"{where}:{reader.line_num}"
        if len(row) != columns.width:
            raise TakeError(f"{line}: {len(row)} fields, the header has {columns.width}")
        rows.append((line, row))
    if not rows:
        raise TakeError(f"{where}: no data rows after the header")
    base = fps if fps is not None else _base(rows, columns.timecode, where)
    times: list[float] = []
    for line, row in rows:
        try:
            t = parse_timecode(row[columns.timecode], base)
        except ValueError as exc:
            raise TakeError(f"{line}: {exc}") from exc
        if times and t < times[-1] - _DAY / 2:  # the take ran past midnight
            t += _DAY
        if times and t <= times[-1]:
            raise TakeError(f"{line}: timecode {row[columns.timecode]} does not advance")
        times.append(t)
    shapes = [[_number(row, c, header, line) for _, c in columns.shapes] for line, row in rows]
    rotations = [[_number(row, c, header, line) for _, c in columns.rotations]
                 for line, row in rows]  # fmt: skip
    take = _assemble(columns, times, shapes, rotations, rotation_factor, where, base)
    for note in take.notes:
        log.warning("%s: %s", where, note)
    return take


def _base(rows: list[tuple[str, list[str]]], column: int, where: str) -> float:
    try:
        return timecode_base([row[column] for _, row in rows])
    except ValueError as exc:
        line = next((line for line, row in rows if _TIMECODE.fullmatch(row[column].strip())
                     is None), where)  # fmt: skip
        raise TakeError(f"{line}: {exc}") from exc


def _number(row: list[str], column: int, header: list[str], line: str) -> float:
    try:
        value = float(row[column])
    except ValueError:
        raise TakeError(
            f"{line}: column {header[column]!r}: {row[column]!r} is not a number"
        ) from None
    if not math.isfinite(value):
        raise TakeError(f"{line}: column {header[column]!r}: {row[column]!r} is not finite")
    return value


def _assemble(
    columns: _Columns, times: list[float], shapes: list[list[float]],
    rotations: list[list[float]], rotation_factor: float, where: str, base: float,
) -> Take:  # fmt: skip
    n = len(times)
    blend = np.zeros((n, N_BLENDSHAPES), dtype=np.float32)
    blend[:, [i for i, _ in columns.shapes]] = np.clip(np.array(shapes, dtype=np.float32), 0, 1)
    angles = np.zeros((n, 9), dtype=np.float32)
    if columns.rotations:
        raw = np.array(rotations, dtype=np.float64) * rotation_factor
        angles[:, [j for j, _ in columns.rotations]] = raw
    t = np.array(times, dtype=np.float64)
    head_columns = {j for j, _ in columns.rotations if j < 3}
    head_off = bool(head_columns) and not np.any(angles[:, sorted(head_columns)])
    notes = (HEAD_OFF_NOTE,) if head_off else ()
    return Take(t - t[0], blend, angles[:, :3].copy(), angles[:, 3:].copy(), where, notes,
                base)  # fmt: skip
