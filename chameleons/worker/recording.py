"""Face-stream recordings: FaceFrames -> a Parquet file, crash-safe while recording.

While recording, frames are buffered and every chunk (``chunk_seconds`` or ``chunk_frames``,
whichever comes first; the recorder stage flushes a chunk that is due while no frame comes)
is appended to a journal next to the target (``<name>.parquet.journal``,
an Arrow IPC stream) and flushed to the OS. A Parquet file is only readable once its footer
is written at close, so the journal is what makes a crash lose at most the last chunk.
:meth:`FrameRecorder.close` turns the journal into the Parquet file (written with
``pyarrow.parquet.ParquetWriter``, then renamed into place) and removes the journal;
:func:`recover_recording` does the same for a journal a crashed worker left behind, and
:func:`read_recording` reads either.

Columns: ``capture_time``, ``receive_time`` (float64 seconds, this host's monotonic clock),
the 52 blendshapes by canonical name, ``head_yaw/pitch/roll`` and ``left_eye_yaw`` ..
``right_eye_roll`` (float32, degrees; a channel the source cannot measure is NaN, e.g. a
webcam's ``cheekPuff``), then ``source`` (which capture source sent the frame:
``livelink``, ``facecapturex``, ``webcam-browser``, ``webcam-python``, ``agent``) and
``calibration`` (a webcam's: ``geometric``, ``neutral``, ``iphone:<hash>``, ...; empty
otherwise). Files of format 1 lack the last two. The schema metadata ``chameleons`` holds a
JSON object with the format version and the caller's metadata (interaction, stream, ...).
"""

from __future__ import annotations

import contextlib
import errno
import json
import os
import re
import time
from collections.abc import Callable
from pathlib import Path
from types import TracebackType
from typing import Any, BinaryIO

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq

from chameleons.worker.frames import BLENDSHAPE_NAMES, EYE_NAMES, N_BLENDSHAPES, FaceFrame
from chameleons.worker.takes import Take

FORMAT_VERSION = 2
METADATA_KEY = b"chameleons"
JOURNAL_SUFFIX = ".journal"
HEAD_COLUMNS = ("head_yaw", "head_pitch", "head_roll")
EYE_COLUMNS = tuple(re.sub(r"(?<!^)(?=[A-Z])", "_", n).lower() for n in EYE_NAMES)
VALUE_COLUMNS = (*BLENDSHAPE_NAMES, *HEAD_COLUMNS, *EYE_COLUMNS)  # FaceFrame.to_vector order
TEXT_COLUMNS = ("source", "calibration")
_ROW_GROUP_ROWS = 65_536  # the final file needs no small row groups any more


class RecordingError(ValueError):
    """A recording that cannot be read."""


FULL_ERRNOS = frozenset({errno.ENOSPC, errno.EDQUOT, errno.EFBIG})
READ_ONLY_ERRNOS = frozenset({errno.EROFS, errno.EACCES, errno.EPERM})


def write_problem(exc: OSError, where: str | Path) -> str:
    """One sentence a wizard can act on, for a recording that cannot be written to ``where``
    (shown on the *Recording* health chip and in the timeline, never the raw exception)."""
    if exc.errno in FULL_ERRNOS:
        return f"The disk is full where recordings are written ({where}): recording stopped."
    if exc.errno in READ_ONLY_ERRNOS:
        return f"The recordings folder {where} is read-only: nothing is being recorded."
    reason = exc.strerror or type(exc).__name__
    return f"Recordings cannot be written to {where} ({reason}): recording stopped."


def recording_schema(metadata: dict[str, Any] | None = None) -> pa.Schema:
    fields = [pa.field("capture_time", pa.float64()), pa.field("receive_time", pa.float64())]
    fields += [pa.field(name, pa.float32()) for name in VALUE_COLUMNS]
    fields += [pa.field(name, pa.string()) for name in TEXT_COLUMNS]
    info = {"version": FORMAT_VERSION, **(metadata or {})}
    return pa.schema(fields, metadata={METADATA_KEY: json.dumps(info).encode()})


def journal_path(path: str | Path) -> Path:
    path = Path(path)
    return path.with_name(path.name + JOURNAL_SUFFIX)


class FrameRecorder:
    """Records FaceFrames to ``path`` (Parquet). Not thread-safe: one writer thread.

    ``write`` buffers; a full chunk goes to the journal and is flushed to the OS (``fsync``
    also to the disk, for power cuts; off by default to keep the worker's timing).
    """

    def __init__(
        self, path: str | Path, *, chunk_seconds: float = 0.5, chunk_frames: int = 64,
        metadata: dict[str, Any] | None = None, fsync: bool = False,
        clock: Callable[[], float] = time.monotonic,
    ) -> None:  # fmt: skip
        self.path = Path(path)
        self.journal = journal_path(self.path)
        for existing in (self.path, self.journal):
            if existing.exists():
                raise FileExistsError(f"recording {existing} exists already")
        self.schema = recording_schema(metadata)
        self.chunk_seconds, self.chunk_frames, self.fsync = chunk_seconds, chunk_frames, fsync
        self.frames_written = 0
        self._clock = clock
        self._times: list[tuple[float, float]] = []
        self._values: list[np.ndarray] = []
        self._texts: list[tuple[str, str]] = []
        self._last_flush = clock()
        self.path.parent.mkdir(parents=True, exist_ok=True)
        self._file: BinaryIO | None = self.journal.open("xb")
        self._writer = pa.ipc.new_stream(self._file, self.schema)
        self._sync()

    def write(self, frame: FaceFrame) -> None:
        if self._file is None:
            raise RuntimeError(f"recording {self.path} is closed")
        self._times.append((frame.capture_time, frame.receive_time))
        self._values.append(frame.recorded_vector())
        self._texts.append((frame.source, frame.calibration))
        due = self._clock() - self._last_flush >= self.chunk_seconds
        if len(self._times) >= self.chunk_frames or due:
            self.flush()

    def flush_if_due(self) -> None:
        """Flush the buffered frames once ``chunk_seconds`` passed since the last chunk,
        also when no frame comes to trigger it (the face left the camera, the phone
        paused): the frames before a pause reach the journal within a chunk's time, not
        only with the next frame, which may never come before a crash."""
        if self._times and self._clock() - self._last_flush >= self.chunk_seconds:
            self.flush()

    def flush(self) -> None:
        """Append the buffered frames to the journal as one chunk."""
        self._last_flush = self._clock()
        if not self._times or self._file is None:
            return
        times = np.array(self._times, dtype=np.float64)
        values = np.stack(self._values).astype(np.float32)
        columns = [pa.array(times[:, 0]), pa.array(times[:, 1])]
        columns += [pa.array(values[:, i]) for i in range(values.shape[1])]
        columns += [pa.array([t[k] for t in self._texts], pa.string()) for k in range(2)]
        self._writer.write_batch(pa.record_batch(columns, schema=self.schema))
        self._sync()
        self.frames_written += len(self._times)
        self._times, self._values, self._texts = [], [], []

    def abandon(self) -> None:
        """Stop after a write error: drop what is buffered and close the journal quietly
        (the chunks written before the error stay recoverable)."""
        self._times, self._values, self._texts = [], [], []
        if self._file is None:
            return
        for close in (self._writer.close, self._file.close):
            # The disk that failed the write fails the close too.
            with contextlib.suppress(OSError, pa.ArrowException):
                close()
        self._file = None

    def close(self) -> Path:
        """Flush, write the Parquet file, remove the journal; returns the Parquet path."""
        if self._file is None:
            return self.path
        self.flush()
        self._writer.close()
        self._file.close()
        self._file = None
        return recover_recording(self.path)

    def _sync(self) -> None:
        assert self._file is not None
        self._file.flush()
        if self.fsync:
            os.fsync(self._file.fileno())

    def __enter__(self) -> FrameRecorder:
        return self

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        self.close()


def _read_journal(path: Path) -> pa.Table:
    """Every complete chunk of a journal; a chunk cut short by a crash is left out."""
    with path.open("rb") as handle:
        try:
            reader = pa.ipc.open_stream(handle)
        except (OSError, pa.ArrowException) as exc:
            raise RecordingError(f"{path}: no readable recording header ({exc})") from exc
        batches = []
        while True:
            try:
                batches.append(reader.read_next_batch())
            except StopIteration:
                break
            except (OSError, pa.ArrowException):  # the chunk being written at the crash
                break
        return pa.Table.from_batches(batches, schema=reader.schema)


def recover_recording(path: str | Path) -> Path:
    """Turn the journal of ``path`` (left by :meth:`FrameRecorder.close` or a crash) into the
    Parquet file and remove the journal. Returns ``path``; a no-op when there is no journal."""
    path = Path(path)
    journal = journal_path(path)
    if not journal.exists():
        return path
    table = _read_journal(journal)
    partial = path.with_name(path.name + ".partial")
    try:
        with pq.ParquetWriter(partial, table.schema, compression="zstd") as writer:
            writer.write_table(table, row_group_size=_ROW_GROUP_ROWS)
    except (OSError, pa.ArrowException):
        with contextlib.suppress(OSError):  # a full disk: keep the journal, no debris
            partial.unlink(missing_ok=True)
        raise
    os.replace(partial, path)  # never a half-written Parquet file under the real name
    journal.unlink()
    return path


def read_recording_table(path: str | Path) -> pa.Table:
    """The recording as an Arrow table: the Parquet file, else its journal (after a crash)."""
    path = Path(path)
    if path.exists():
        try:
            return pq.read_table(path)
        except (OSError, pa.ArrowException) as exc:
            raise RecordingError(f"{path}: not a readable Parquet recording ({exc})") from exc
    if journal_path(path).exists():
        return _read_journal(journal_path(path))
    raise RecordingError(f"{path}: no such recording")


def recording_metadata(table: pa.Table) -> dict[str, Any]:
    raw = (table.schema.metadata or {}).get(METADATA_KEY, b"{}")
    info: dict[str, Any] = json.loads(raw)
    return info


def read_recording(path: str | Path) -> Take:
    """A recording as a :class:`Take` (e.g. a participant's stream replayed as ``natural``);
    missing channels (NaN) replay at rest (0).

    Times come from ``capture_time`` relative to the first frame; if those do not increase
    strictly (the sender's clock restarted), from ``receive_time`` instead."""
    table = read_recording_table(path)
    missing = [
        c for c in ("capture_time", "receive_time", *VALUE_COLUMNS) if c not in table.column_names
    ]
    if missing:
        raise RecordingError(f"{path}: missing columns {', '.join(missing)}")
    if table.num_rows == 0:
        raise RecordingError(f"{path}: no frames")
    values = np.column_stack([table.column(c).to_numpy() for c in VALUE_COLUMNS]).astype(np.float32)
    values = np.nan_to_num(values, nan=0.0)  # a replayed face rests where a channel is missing
    times = table.column("capture_time").to_numpy().astype(np.float64)
    if np.any(np.diff(times) <= 0):
        times = table.column("receive_time").to_numpy().astype(np.float64)
    n = N_BLENDSHAPES
    return Take(
        times - times[0], values[:, :n].copy(), values[:, n : n + 3].copy(),
        values[:, n + 3 :].copy(), str(path),
    )  # fmt: skip


def recorded_sources(path: str | Path) -> dict[tuple[str, str], int]:
    """(source, calibration) -> frames, from a recording's ``source`` and ``calibration``
    columns (a format-1 file: empty)."""
    table = read_recording_table(path)
    if "source" not in table.column_names:
        return {}
    sources = table.column("source").to_pylist()
    calibrations = (table.column("calibration").to_pylist()
                    if "calibration" in table.column_names else [""] * len(sources))  # fmt: skip
    counts: dict[tuple[str, str], int] = {}
    for pair in zip(sources, calibrations, strict=True):
        key = (pair[0] or "", pair[1] or "")
        counts[key] = counts.get(key, 0) + 1
    return counts
