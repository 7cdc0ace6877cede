"""``chameleons import-xdf``: attach the streams of an XDF recording (LabRecorder's file of
EMG, eye tracking, physiology, other tools' markers) to a session's timeline.

Alignment: the recording holds this system's ``Markers`` stream (``chameleons-<booth>-
events``, :mod:`chameleons.instruments.lsl`), each marker naming the timeline event it
stands for. pyxdf puts every stream on the recorder's clock (its ClockOffset chunks); the
markers' times on that clock, paired with their events' server times, fit the mapping from
the recorder's clock to the server's (an offset, and a rate once the markers span a minute
or more). Each stream's samples are then stored with their time from the session's start on
the server's clock, in a Parquet file under ``<data dir>/instruments/session-<id>/``.
"""

from __future__ import annotations

import re
from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import pyarrow as pa
import pyarrow.parquet as pq
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.instruments.retention import session_folder
from chameleons.backend.models import Event, InstrumentStream, Session
from chameleons.instruments.lsl import parse_marker

OWN_PREFIX = "chameleons-"

MIN_SLOPE_SPAN_S = 60.0  # markers spanning less than this fit an offset only
MAX_SLOPE_ERROR = 1e-3  # a fitted rate further from 1 than this is not a clock: offset only


class XdfImportError(ValueError):
    """Why a file could not be attached, in one sentence."""


@dataclass(frozen=True, slots=True)
class ClockFit:
    """server epoch seconds = ``slope`` x recorder clock + ``offset``."""

    offset: float
    slope: float
    markers: int
    residual_ms: float
    marker_stream: str

    def to_server(self, times: Any) -> Any:
        return self.slope * np.asarray(times, dtype=np.float64) + self.offset

    def to_dict(self) -> dict[str, Any]:
        return {"offset": self.offset, "slope": self.slope, "markers": self.markers,
                "residual_ms": self.residual_ms, "marker_stream": self.marker_stream}  # fmt: skip


@dataclass(frozen=True, slots=True)
class ImportResult:
    fit: ClockFit
    streams: list[InstrumentStream]
    skipped: list[str]


def fit_clock(recorder: list[float], server: list[float], marker_stream: str) -> ClockFit:
    """The recorder-to-server mapping from matched (recorder time, server time) pairs."""
    x, y = np.asarray(recorder, dtype=np.float64), np.asarray(server, dtype=np.float64)
    slope = 1.0
    if len(x) >= 3 and float(x.max() - x.min()) >= MIN_SLOPE_SPAN_S:
        centre = x.mean()
        fitted = float(np.polyfit(x - centre, y, 1)[0])
        if abs(fitted - 1.0) <= MAX_SLOPE_ERROR:
            slope = fitted
    offset = float(np.median(y - slope * x))
    residual = float(np.max(np.abs(y - (slope * x + offset)))) if len(x) else 0.0
    return ClockFit(offset, slope, len(x), round(residual * 1000, 3), marker_stream)


def _text(info: dict[str, Any], key: str, default: str = "") -> str:
    value = info.get(key)
    if isinstance(value, list) and value:
        value = value[0]
    return default if value is None else str(value)


def channel_labels(info: dict[str, Any]) -> list[str]:
    """The labels in the stream description, ``ch1``.. where there are none (or repeats)."""
    count = int(float(_text(info, "channel_count", "0")))
    labels: list[str] = []
    try:
        channels = info["desc"][0]["channels"][0]["channel"]
        labels = [_text(channel, "label") for channel in channels]
    except (KeyError, IndexError, TypeError):
        pass
    names: list[str] = []
    for i in range(count):
        label = labels[i].strip() if i < len(labels) else ""
        if not label or label in names or label in ("time", "lsl_time", "value"):
            label = f"ch{i + 1}"
        names.append(label)
    return names


def load(path: Path) -> list[dict[str, Any]]:
    import pyxdf

    if not path.is_file():
        raise XdfImportError(f"There is no file {path}.")
    with path.open("rb") as file:
        magic = file.read(4)
    # XDF's magic, or gzip's (pyxdf reads .xdfz); checked here: pyxdf leaves its file open
    # when it refuses one.
    if magic != b"XDF:" and magic[:2] != b"\x1f\x8b":
        raise XdfImportError(f"{path.name} is not a readable XDF file (no XDF: at its start).")
    try:
        streams, _header = pyxdf.load_xdf(str(path))
    except Exception as exc:  # pyxdf raises whatever a broken file makes it raise
        raise XdfImportError(f"{path.name} is not a readable XDF file ({exc}).") from exc
    return list(streams)


def _epoch(moment: datetime) -> float:
    return (moment if moment.tzinfo else moment.replace(tzinfo=UTC)).timestamp()


def match_markers(streams: list[dict[str, Any]], events: dict[int, Event],
                  session_id: int) -> ClockFit:  # fmt: skip
    """Fit the clock on the best of the recording's streams of this system's markers."""
    best: ClockFit | None = None
    for stream in streams:
        if _text(stream["info"], "type").lower() != "markers":
            continue
        recorder, server = [], []
        for sample, stamp in zip(stream["time_series"], stream["time_stamps"], strict=False):
            marker = parse_marker(str(sample[0])) if len(sample) else None
            if marker is None or marker.get("session_id") != session_id:
                continue
            event = events.get(marker["event_id"])
            if event is None or event.kind != marker["kind"]:
                continue
            recorder.append(float(stamp))
            server.append(_epoch(event.server_time))
        if recorder:
            fit = fit_clock(recorder, server, _text(stream["info"], "name"))
            if best is None or fit.markers > best.markers:
                best = fit
    if best is None:
        raise XdfImportError(
            f"The recording has no markers of session {session_id} from this system: record "
            "the chameleons-<booth>-events stream (server with CHAMELEONS_LSL=1) beside the "
            "other instruments."
        )
    return best


def _slug(text: str) -> str:
    return re.sub(r"[^A-Za-z0-9_.-]+", "-", text).strip("-.")[:80] or "stream"


def _table(stream: dict[str, Any], labels: list[str], fit: ClockFit,
           zero: float) -> pa.Table:  # fmt: skip
    stamps = np.asarray(stream["time_stamps"], dtype=np.float64)
    columns: dict[str, Any] = {"time": fit.to_server(stamps) - zero, "lsl_time": stamps}
    series = stream["time_series"]
    if _text(stream["info"], "channel_format") == "string":
        columns["value"] = [" | ".join(str(v) for v in sample) for sample in series]
    else:
        values = np.asarray(series, dtype=np.float64).reshape(len(stamps), len(labels))
        for i, label in enumerate(labels):
            columns[label] = values[:, i]
    return pa.table(columns)


def import_xdf(db: DbSession, session_id: int, path: Path, data_dir: Path, *,
               include_own: bool = False) -> ImportResult:  # fmt: skip
    """Attach the other instruments' streams of ``path`` to the session; a stream imported
    before (same name and source id) is replaced. This system's own streams (its markers
    and faces, recorded by the worker already) are left out unless ``include_own``."""
    session = db.get(Session, session_id)
    if session is None:
        raise XdfImportError(f"There is no session {session_id}.")
    streams = load(path)
    events = {e.id: e for e in db.scalars(select(Event).where(Event.session_id == session_id))}
    fit = match_markers(streams, events, session_id)
    start = session.started_at or min((e.server_time for e in events.values()), default=None)
    zero = _epoch(start) if start is not None else 0.0
    folder = session_folder(data_dir, session_id)
    folder.mkdir(parents=True, exist_ok=True)
    stored, skipped = [], []
    for stream in streams:
        info = stream["info"]
        name = _text(info, "name", "unnamed")
        if name.startswith(OWN_PREFIX) and not include_own:
            skipped.append(name)
            continue
        source_id = _text(info, "source_id")
        labels = channel_labels(info)
        table = _table(stream, labels, fit, zero)
        target = folder / f"{_slug(name)}-{_slug(source_id)[:24] or 'x'}.parquet"
        pq.write_table(table, target)
        row = db.scalar(select(InstrumentStream).where(
            InstrumentStream.session_id == session_id, InstrumentStream.name == name,
            InstrumentStream.source_id == source_id))  # fmt: skip
        if row is None:
            row = InstrumentStream(session_id=session_id, name=name, source_id=source_id)
            db.add(row)
        times = table.column("time").to_numpy()
        row.stream_type = _text(info, "type")
        row.channel_format = _text(info, "channel_format", "float32")
        row.nominal_srate = float(_text(info, "nominal_srate", "0") or 0)
        row.channels = labels
        row.samples = table.num_rows
        row.first_s = float(times[0]) if len(times) else None
        row.last_s = float(times[-1]) if len(times) else None
        row.path = str(target.relative_to(data_dir))
        row.source_file = path.name
        row.fit = fit.to_dict()
        row.imported_at = datetime.now(UTC)
        stored.append(row)
    db.flush()
    return ImportResult(fit, stored, skipped)


def streams_of(db: DbSession, session_id: int) -> list[InstrumentStream]:
    query = select(InstrumentStream).where(InstrumentStream.session_id == session_id)
    return list(db.scalars(query.order_by(InstrumentStream.id)))
