"""``chameleons export --instruments``: the imported instrument streams of a study's
sessions, as Parquet files beside an index (``instruments/streams.csv``)."""

from __future__ import annotations

import csv
import json
import shutil
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.models import InstrumentStream, Participant, Session

if TYPE_CHECKING:
    from chameleons.backend.instruments.eaf import LinkedMedia

INDEX_COLUMNS = ("participant", "session_id", "stream", "stream_type", "source_id",
                 "channel_format", "nominal_srate", "channels", "samples", "first_s",
                 "last_s", "file", "source_file", "clock_fit")  # fmt: skip


def export_instruments(db: DbSession, study_id: int, include_rehearsal: bool, data_dir: Path,
                       out: Path) -> int:  # fmt: skip
    """Copy each stream's Parquet file to ``out/instruments/`` and index them; returns how
    many streams were written (a stream whose file is gone is indexed with no file)."""
    query = (select(InstrumentStream, Participant.code)
             .join(Session, Session.id == InstrumentStream.session_id)
             .join(Participant, Participant.id == Session.participant_id)
             .where(Session.study_id == study_id)
             .order_by(Participant.code, InstrumentStream.id))  # fmt: skip
    if not include_rehearsal:
        query = query.where(Session.is_rehearsal.is_(False))
    folder = out / "instruments"
    rows = []
    for stream, code in db.execute(query).tuples():
        source = data_dir / stream.path
        name = f"{code}-session{stream.session_id}-{Path(stream.path).name}"
        if source.is_file():
            folder.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(source, folder / name)
        rows.append([code, stream.session_id, stream.name, stream.stream_type, stream.source_id,
                     stream.channel_format, stream.nominal_srate, "|".join(stream.channels),
                     stream.samples, stream.first_s, stream.last_s,
                     name if source.is_file() else "", stream.source_file,
                     json.dumps(stream.fit, sort_keys=True)])  # fmt: skip
    if rows:
        folder.mkdir(parents=True, exist_ok=True)
        with (folder / "streams.csv").open("w", newline="", encoding="utf-8") as file:
            writer = csv.writer(file)
            writer.writerow(INDEX_COLUMNS)
            writer.writerows(rows)
    return len(rows)


def export_eaf(db: DbSession, study_id: int, include_rehearsal: bool, out: Path,
               media: Mapping[int, Sequence[LinkedMedia]] | None = None) -> int:  # fmt: skip
    """``out/eaf/<code>-session<id>.eaf`` for each session of the study (coders' template),
    linked to the session's videos in ``media`` (by session id), and
    ``out/eaf/reliability.csv`` once coders' annotations have been imported."""
    from chameleons.backend.instruments.eaf import write_eaf
    from chameleons.backend.instruments.reliability import study_reliability

    query = (select(Session.id, Participant.code)
             .join(Participant, Participant.id == Session.participant_id)
             .where(Session.study_id == study_id)
             .order_by(Participant.code, Session.id))  # fmt: skip
    if not include_rehearsal:
        query = query.where(Session.is_rehearsal.is_(False))
    written = 0
    for session_id, code in db.execute(query).tuples():
        write_eaf(db, session_id, out / "eaf" / f"{code}-session{session_id}.eaf",
                  media=(media or {}).get(session_id, ()))  # fmt: skip
        written += 1
    tiers = study_reliability(db, study_id)
    if tiers:
        (out / "eaf").mkdir(parents=True, exist_ok=True)
        with (out / "eaf" / "reliability.csv").open("w", newline="", encoding="utf-8") as file:
            writer = csv.writer(file)
            writer.writerow(RELIABILITY_COLUMNS)
            for tier in tiers:
                for pair, kappa in (tier.cohen or {"": None}).items():
                    writer.writerow([tier.tier, "|".join(tier.coders), tier.sessions, tier.units,
                                     pair, kappa, tier.fleiss, tier.alpha])  # fmt: skip
    return written


RELIABILITY_COLUMNS = ("tier", "coders", "sessions", "units", "coder_pair", "cohen_kappa",
                       "fleiss_kappa", "krippendorff_alpha")  # fmt: skip
