"""Lip-sync curves of a prompt: times plus mouth/jaw blendshape channels.

File format: CSV, a header row with a ``time`` column (seconds from the start of the audio)
and ARKit blendshape columns in any spelling (``jawOpen``, ``JawOpen``, ``JAW_OPEN``...).
Tolerated: a UTF-8 byte-order mark, CRLF, blank lines and ``#`` comment lines, spaces
around cells, columns in any order, values slightly outside 0..1 (clamped), unknown columns
and non-mouth channels (ignored, listed in ``LipSync.ignored``). Anything else — a missing
time column, a short row, a non-number, NaN/inf, times that do not increase — is a
:class:`LipSyncError` naming the file and line.
"""

from __future__ import annotations

import csv
import math
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import numpy.typing as npt

from chameleons.worker.frames import BLENDSHAPE_NAMES, MOUTH_JAW_INDICES, F32Array, canonical_name

F64Array = npt.NDArray[np.float64]
TIME_COLUMNS = ("time", "time_s", "seconds", "t")
LIPSYNC_NAMES: tuple[str, ...] = tuple(BLENDSHAPE_NAMES[i] for i in MOUTH_JAW_INDICES)
_LIPSYNC_POSITION = {name: k for k, name in enumerate(LIPSYNC_NAMES)}


class LipSyncError(ValueError):
    """A lip-sync file that cannot be used; the message says where and why."""


@dataclass(frozen=True, slots=True)
class LipSync:
    """``values[:, k]`` is channel ``LIPSYNC_NAMES[k]`` (``MOUTH_JAW_INDICES[k]`` in a face
    vector); channels the file lacks are zero. ``channels`` lists those it has."""

    times: F64Array
    values: F32Array
    channels: tuple[str, ...]
    ignored: tuple[str, ...] = ()

    @property
    def duration(self) -> float:
        return float(self.times[-1])

    @classmethod
    def from_arrays(cls, times: npt.ArrayLike, curves: Mapping[str, npt.ArrayLike]) -> LipSync:
        """Build from arrays: ``curves`` maps blendshape names to values per time."""
        t = np.asarray(times, dtype=np.float64).reshape(-1)
        values = np.zeros((len(t), len(LIPSYNC_NAMES)), dtype=np.float32)
        channels, ignored = [], []
        for raw, column in curves.items():
            name = canonical_name(raw)
            if name not in _LIPSYNC_POSITION:
                ignored.append(raw)
                continue
            values[:, _LIPSYNC_POSITION[name]] = np.asarray(column, dtype=np.float32)
            channels.append(name)
        _check(t, values, channels)
        return cls(t, np.clip(values, 0.0, 1.0), tuple(channels), tuple(ignored))


def _check(times: F64Array, values: F32Array, channels: list[str]) -> None:
    if len(times) == 0:
        raise LipSyncError("no rows")
    if not channels:
        raise LipSyncError("no mouth or jaw blendshape columns")
    if not (np.all(np.isfinite(times)) and np.all(np.isfinite(values))):
        raise LipSyncError("NaN or infinite values")
    if np.any(np.diff(times) <= 0):
        raise LipSyncError("times must increase from row to row")


def load_lipsync(path: str | Path) -> LipSync:
    """Read a lip-sync CSV (see the module docstring)."""
    path = Path(path)
    try:
        text = path.read_text(encoding="utf-8-sig")
    except FileNotFoundError as exc:
        raise LipSyncError(f"{path}: lip-sync file not found") from exc
    except (OSError, UnicodeDecodeError) as exc:
        raise LipSyncError(f"{path}: cannot read: {exc}") from exc
    rows = [
        (number, [cell.strip() for cell in row])
        for number, row in enumerate(csv.reader(text.splitlines()), start=1)
        if row and any(cell.strip() for cell in row) and not row[0].lstrip().startswith("#")
    ]
    if not rows:
        raise LipSyncError(f"{path}: empty file")
    header_line, header = rows[0]
    lowered = [cell.lower() for cell in header]
    time_index = next((lowered.index(c) for c in TIME_COLUMNS if c in lowered), None)
    if time_index is None:
        raise LipSyncError(f"{path}:{header_line}: no 'time' column in header {header}")
    data = np.empty((len(rows) - 1, len(header)), dtype=np.float64)
    for r, (line, cells) in enumerate(rows[1:]):
        if len(cells) != len(header):
            raise LipSyncError(f"{path}:{line}: {len(cells)} cells, header has {len(header)}")
        for c, cell in enumerate(cells):
            data[r, c] = _number(cell, path, line, header[c])
    curves = {name: data[:, c] for c, name in enumerate(header) if c != time_index}
    try:
        return LipSync.from_arrays(data[:, time_index], curves)
    except LipSyncError as exc:
        raise LipSyncError(f"{path}: {exc}") from exc


def _number(cell: str, path: Path, line: int, column: str) -> float:
    try:
        value = float(cell)
    except ValueError:
        raise LipSyncError(f"{path}:{line}: {column} is not a number: {cell!r}") from None
    if not math.isfinite(value):
        raise LipSyncError(f"{path}:{line}: {column} is not finite: {cell!r}")
    return value
