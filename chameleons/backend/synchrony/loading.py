"""Recordings into face streams for :mod:`chameleons.experiment.stats.synchrony`.

An interaction's stream may be in several files (``-part2``... after a worker restart):
their frames are joined on the worker's clock, and the time between parts is a capture
gap. Frame times are ``capture_time`` (on the worker's clock: the ingest aligns the
sender's clock to it; the robot's are its send ticks), or ``receive_time`` when those do
not increase (a sender whose clock restarted), as :func:`read_recording` does.
"""

from __future__ import annotations

from collections import Counter
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pyarrow as pa

from chameleons.worker.frames import BLENDSHAPE_NAMES
from chameleons.worker.recording import HEAD_COLUMNS, RecordingError, read_recording_table

CHANNELS: tuple[str, ...] = (*HEAD_COLUMNS, *BLENDSHAPE_NAMES)


@dataclass(frozen=True)
class LoadedStream:
    times: np.ndarray
    values: np.ndarray
    source: str | None  # the capture source most frames came from (format 2 files)


def load_stream(paths: Sequence[Path]) -> LoadedStream:
    """The frames of one stream's files, joined in time order. Raises RecordingError."""
    times, values, sources = [], [], Counter[str]()
    for path in paths:
        table = read_recording_table(path)
        if "capture_time" not in table.column_names:
            raise RecordingError(f"{path}: no capture_time column")
        if table.num_rows == 0:
            continue
        times.append(_times(table))
        values.append(np.column_stack([_column(table, c) for c in CHANNELS]))
        if "source" in table.column_names:
            sources.update(s for s in table.column("source").to_pylist() if s)
    if not times:
        return LoadedStream(np.empty(0), np.empty((0, len(CHANNELS))), None)
    source = sources.most_common(1)[0][0] if sources else None
    return LoadedStream(np.concatenate(times), np.vstack(values), source)


def _times(table: pa.Table) -> np.ndarray:
    capture = table.column("capture_time").to_numpy().astype(np.float64)
    restarted = len(capture) > 1 and np.any(np.diff(capture) <= 0)
    if restarted and "receive_time" in table.column_names:
        return np.asarray(table.column("receive_time").to_numpy(), dtype=np.float64)
    return np.asarray(capture, dtype=np.float64)


def _column(table: pa.Table, name: str) -> np.ndarray:
    if name not in table.column_names:
        return np.full(table.num_rows, np.nan)
    return np.asarray(table.column(name).to_numpy(zero_copy_only=False), dtype=np.float64)
