"""Live Link Face take CSVs (protocols.md 2b) -> :class:`Take`.

A take's header names its columns: ``Timecode, BlendShapeCount``, the 52 blendshapes in
PascalCase and ``HeadYaw .. RightEyeRoll``. The column order differs from the UDP order, so
columns are mapped by name (any spelling :func:`canonical_name` knows), never by position.
Time comes from the ``Timecode`` ``HH:MM:SS:FF.fff`` on a 60 fps base (``.fff`` a fraction
of a frame), never from the row index: rows may advance by 1 or 2 frames (60 or 30 Hz).
Head and eye columns use the Live Link rotation unit (see
:mod:`chameleons.worker.ingest.livelink`); they are all zero unless head rotation streaming
was on in the app. Missing head/eye columns read as zero; a missing ``TongueOut`` too.
"""

from __future__ import annotations

import csv
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

F64Array = npt.NDArray[np.float64]
TIMECODE_FPS = 60
_TIMECODE = re.compile(r"(\d{1,2}):(\d{2}):(\d{2})[:;.](\d{1,3})(?:\.(\d+))?")
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


def parse_timecode(text: str, fps: int = TIMECODE_FPS) -> float:
    """``HH:MM:SS:FF.fff`` -> seconds since midnight (``FF.fff`` frames at ``fps``)."""
    match = _TIMECODE.fullmatch(text.strip())
    if match is None:
        raise ValueError(f"timecode {text!r} is not HH:MM:SS:FF.fff")
    hours, minutes, seconds, frames = (int(g) for g in match.groups()[:4])
    fraction = float("0." + match.group(5)) if match.group(5) else 0.0
    if minutes > 59 or seconds > 59 or frames >= fps:
        raise ValueError(f"timecode {text!r} is out of range for {fps} fps")
    return hours * 3600 + minutes * 60 + seconds + (frames + fraction) / fps


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
    path: str | Path, *, rotation_factor: float = DEFAULT_ROTATION_FACTOR, fps: int = TIMECODE_FPS
) -> Take:
    """Read a Live Link Face take CSV; raises :class:`TakeError` naming file and line."""
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


def _read(reader: csv.Reader, where: str, rotation_factor: float, fps: int) -> Take:  # type: ignore[name-defined]
    header = next(reader, None)
    if not header:
        raise TakeError(f"{where}:1: empty file, expected a header row")
    columns = _Columns(header, where)
    times: list[float] = []
    shapes: list[list[float]] = []
    rotations: list[list[float]] = []
    for row in reader:
        if not any(cell.strip() for cell in row):
            continue
        line = f"{where}:{reader.line_num}"
        if len(row) != columns.width:
            raise TakeError(f"{line}: {len(row)} fields, the header has {columns.width}")
        try:
            t = parse_timecode(row[columns.timecode], fps)
        except ValueError as exc:
            raise TakeError(f"{line}: {exc}") from exc
        if times and t < times[-1] - _DAY / 2:  # the take ran past midnight
            t += _DAY
        if times and t <= times[-1]:
            raise TakeError(f"{line}: timecode {row[columns.timecode]} does not advance")
        times.append(t)
        shapes.append([_number(row, c, header, line) for _, c in columns.shapes])
        rotations.append([_number(row, c, header, line) for _, c in columns.rotations])
    if not times:
        raise TakeError(f"{where}: no data rows after the header")
    return _assemble(columns, times, shapes, rotations, rotation_factor, where)


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
    rotations: list[list[float]], rotation_factor: float, where: str,
) -> Take:  # fmt: skip
    n = len(times)
    blend = np.zeros((n, N_BLENDSHAPES), dtype=np.float32)
    blend[:, [i for i, _ in columns.shapes]] = np.clip(np.array(shapes, dtype=np.float32), 0, 1)
    angles = np.zeros((n, 9), dtype=np.float32)
    if columns.rotations:
        raw = np.array(rotations, dtype=np.float64) * rotation_factor
        angles[:, [j for j, _ in columns.rotations]] = raw
    t = np.array(times, dtype=np.float64)
    return Take(t - t[0], blend, angles[:, :3].copy(), angles[:, 3:].copy(), where)
