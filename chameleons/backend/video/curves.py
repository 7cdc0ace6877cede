"""The faces for the replay: a few of the participant's and the robot's channels from the
session's recordings, on the server's clock, a few samples a second.

The recordings' times are the worker's monotonic clock; the timeline's events the worker
reported (prompts played, speech) carry both clocks, so the median of their differences
maps one onto the other (within the events' relay time, milliseconds on a healthy booth).
"""

from __future__ import annotations

import statistics
import warnings
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import Event, Interaction, Recording
from chameleons.worker.recording import RecordingError, read_recording_table

RATE_HZ = 5.0
# Frames further than this from the session's origin are not the session's (a clock that
# jumped): left out rather than binned over hours.
SPAN_S = (-600.0, 6 * 3600.0)
# What the replay draws: a curve's name -> the channels averaged into it.
CURVES: dict[str, tuple[str, ...]] = {
    "smile": ("mouthSmileLeft", "mouthSmileRight"),
    "jaw open": ("jawOpen",),
    "brows up": ("browInnerUp",),
    "head yaw (deg)": ("head_yaw",),
}
STREAMS = {"participant": "participant", "agent": "robot"}
CHANNELS = tuple(sorted({c for channels in CURVES.values() for c in channels}))


def load_stream(paths: list[Path]) -> tuple[np.ndarray, np.ndarray]:
    """(times on the worker's clock, values of :data:`CHANNELS`) of one stream's files;
    ``capture_time``, or ``receive_time`` where those do not increase (a sender whose clock
    restarted), as the synchrony's loader reads them. Raises RecordingError."""
    times, values = [], []
    for path in paths:
        table = read_recording_table(path)
        if table.num_rows == 0 or "capture_time" not in table.column_names:
            continue
        stamp = table.column("capture_time").to_numpy().astype(np.float64)
        if np.any(np.diff(stamp) <= 0) and "receive_time" in table.column_names:
            stamp = table.column("receive_time").to_numpy().astype(np.float64)
        times.append(stamp)
        values.append(np.column_stack([
            np.asarray(table.column(c).to_numpy(zero_copy_only=False), dtype=np.float64)
            if c in table.column_names else np.full(table.num_rows, np.nan)
            for c in CHANNELS
        ]))  # fmt: skip
    if not times:
        return np.empty(0), np.empty((0, len(CHANNELS)))
    return np.concatenate(times), np.vstack(values)


def _epoch(moment: datetime) -> float:
    return (moment if moment.tzinfo else moment.replace(tzinfo=UTC)).timestamp()


def worker_offset(db: DbSession, session_id: int) -> float | None:
    """Server epoch seconds minus the worker's clock, from the session's events that carry
    both; None when none does."""
    query = select(Event.server_time, Event.worker_time).where(
        Event.session_id == session_id, Event.worker_time.is_not(None)
    )
    rows = db.execute(query)
    differences = [_epoch(at) - float(worker) for at, worker in rows.tuples()
                   if worker is not None]  # fmt: skip
    return statistics.median(differences) if differences else None


def _binned(times: np.ndarray, values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Means over bins of 1/RATE_HZ s (NaN ignored; an empty bin is dropped)."""
    bins = np.floor(times * RATE_HZ).astype(np.int64)
    first = int(bins.min())
    index = bins - first
    ok = ~np.isnan(values)
    sums = np.bincount(index[ok], weights=values[ok], minlength=int(index.max()) + 1)
    counts = np.bincount(index[ok], minlength=int(index.max()) + 1)
    kept = counts > 0
    centres = (np.arange(len(counts)) + first + 0.5) / RATE_HZ
    return centres[kept], sums[kept] / counts[kept]


def session_curves(db: DbSession, session_id: int, data_dir: Path,
                   origin: datetime) -> dict[str, Any]:  # fmt: skip
    """``{"curves": [...names], "streams": {"participant"|"robot": {"t": [...], name: [...]}},
    "reason": text}``: times in seconds from ``origin``."""
    result: dict[str, Any] = {"curves": list(CURVES), "streams": {}, "reason": ""}
    query = (select(Recording.stream, Recording.path)
             .join(Interaction, Interaction.id == Recording.interaction_id)
             .where(Interaction.session_id == session_id)
             .order_by(Interaction.position, Recording.path))  # fmt: skip
    paths: dict[str, list[Path]] = {}
    for stream, stored in db.execute(query).tuples():
        path = Path(stored) if Path(stored).is_absolute() else data_dir / stored
        if path.is_file():
            paths.setdefault(stream, []).append(path)
    if not paths:
        result["reason"] = "No face recordings of this session."
        return result
    offset = worker_offset(db, session_id)
    if offset is None:
        result["reason"] = (
            "The face recordings cannot be placed on the timeline (no event "
            "of this session carries the worker's clock)."
        )
        return result
    shift = offset - _epoch(origin)
    for stream, files in paths.items():
        try:
            stamps, table = load_stream(files)
        except RecordingError as exc:
            result["reason"] = str(exc)
            continue
        if len(stamps) == 0:
            continue
        times = stamps + shift
        inside = (times > SPAN_S[0]) & (times < SPAN_S[1])
        times, table = times[inside], table[inside]
        if len(times) == 0:
            continue
        curve: dict[str, list[float | None]] = {}
        centres = None
        for name, channels in CURVES.items():
            columns = [CHANNELS.index(c) for c in channels]
            with warnings.catch_warnings():  # a frame without the channel: NaN, skipped
                warnings.simplefilter("ignore", RuntimeWarning)
                values = np.nanmean(table[:, columns], axis=1)
            if centres is None:
                centres, _ = _binned(times, np.zeros_like(times))
            grid, means = _binned(times, values)
            lookup = dict(zip(np.round(grid, 3).tolist(), np.round(means, 3).tolist(), strict=True))
            curve[name] = [lookup.get(t) for t in np.round(centres, 3).tolist()]
        result["streams"][STREAMS.get(stream, stream)] = {
            "t": np.round(centres, 3).tolist() if centres is not None else [],
            **curve,
        }
    return result
