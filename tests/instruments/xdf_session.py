"""A session with an XDF recording made beside it, as LabRecorder would have written it:
this system's markers from the server's machine, a two-channel EMG at 50 Hz and a
PsychoPy-style marker stream from another machine whose LSL clock reads differently, and
the worker's own face stream. Not a test module."""

from __future__ import annotations

from dataclasses import dataclass
from datetime import UTC, datetime
from pathlib import Path

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.events.repository import to_dict
from chameleons.backend.models import Event, Session
from chameleons.instruments.lsl import marker_text
from tests.instruments.xdf_writer import XdfStream, write_xdf
from tests.support.factories import populate

SERVER_OFFSET = 12.5  # the recorder's clock minus the server machine's LSL clock
EMG_OFFSET = -300.25  # the recorder's clock minus the EMG machine's
EMG_RATE = 50.0


def epoch(moment: datetime) -> float:
    return (moment if moment.tzinfo else moment.replace(tzinfo=UTC)).timestamp()


@dataclass(frozen=True)
class Recorded:
    session_id: int
    path: Path
    events: int
    burst_s: float  # when the EMG burst and the stimulus marker happened, from the start


def recorded_session(db: DbSession, tmp_path: Path, *, session_markers: bool = True) -> Recorded:
    study = populate(db, participants=1)
    session_id = study.session_ids[0]
    db.flush()
    session = db.get(Session, session_id)
    assert session is not None
    assert session.started_at is not None
    events = list(db.scalars(select(Event).where(Event.session_id == session_id)
                             .order_by(Event.server_time)))  # fmt: skip
    zero = epoch(session.started_at)
    lsl_zero = zero - 5000.0  # the server's LSL clock read 5000 s at the session's start
    target = epoch(events[len(events) // 2].server_time)
    marked = events if session_markers else []
    markers = XdfStream(1, f"chameleons-{session.booth}-events", "Markers", "string", 0.0,
                        [epoch(e.server_time) - lsl_zero for e in marked],
                        [[marker_text(to_dict(e))] for e in marked],
                        source_id="chameleons-events", offset=SERVER_OFFSET)  # fmt: skip
    end = max(epoch(e.server_time) for e in events) + 5.0
    count = int((end - zero) * EMG_RATE)
    server_times = [zero + k / EMG_RATE for k in range(count)]

    def on_emg(t: float) -> float:  # the server time t on the EMG machine's clock
        return t - lsl_zero + SERVER_OFFSET - EMG_OFFSET

    emg = XdfStream(2, "BioSemi", "EMG", "float32", EMG_RATE,
                    [on_emg(t) for t in server_times],
                    [[1.0 if abs(t - target) < 0.1 else 0.0, 0.25] for t in server_times],
                    labels=["zygomaticus", "corrugator"], source_id="biosemi-1",
                    offset=EMG_OFFSET)  # fmt: skip
    stimulus = XdfStream(
        3,
        "PsychoPy",
        "Markers",
        "string",
        0.0,
        [on_emg(target)],
        [["stimulus_on"]],
        source_id="psychopy",
        offset=EMG_OFFSET,
    )
    face = XdfStream(4, f"chameleons-{session.booth}-participant", "Face", "float32", 0.0,
                     [on_emg(zero + 1.0), on_emg(zero + 2.0)], [[0.5] * 61, [0.5] * 61],
                     source_id="face", offset=EMG_OFFSET)  # fmt: skip
    path = write_xdf(tmp_path / "beside.xdf", [markers, emg, stimulus, face])
    return Recorded(session_id, path, len(marked), target - zero)
