"""``chameleons import-xdf``: a real XDF file (written to the specification, read by
pyxdf) lands on the session's timeline through the markers this system sent."""

from __future__ import annotations

import csv
import secrets
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest
from click.testing import CliRunner
from sqlalchemy import select
from sqlalchemy.orm import Session as DbSession

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.instruments.xdf_import import XdfImportError, import_xdf, streams_of
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import InstrumentStream
from chameleons.cli.main import cli
from tests.instruments.xdf_session import recorded_session


def read_csv_rows(path: Path) -> list[dict[str, str]]:
    with path.open(newline="", encoding="utf-8") as file:
        return list(csv.DictReader(file))


@pytest.mark.slow
def test_the_other_instruments_land_on_the_timeline(db_session: DbSession,
                                                    tmp_path: Path) -> None:  # fmt: skip
    recorded = recorded_session(db_session, tmp_path)
    data = tmp_path / "data"
    result = import_xdf(db_session, recorded.session_id, recorded.path, data)
    db_session.commit()
    assert result.fit.markers == recorded.events
    assert result.fit.residual_ms < 1.0
    assert result.skipped == [n for n in result.skipped if n.startswith("chameleons-")]
    assert len(result.skipped) == 2  # this system's markers and face stream
    rows = {row.name: row for row in streams_of(db_session, recorded.session_id)}
    assert set(rows) == {"BioSemi", "PsychoPy"}
    emg = rows["BioSemi"]
    assert emg.channels == ["zygomaticus", "corrugator"]
    assert emg.stream_type == "EMG"
    assert emg.nominal_srate == 50.0
    assert emg.first_s == pytest.approx(0.0, abs=0.01)
    table = pq.read_table(data / emg.path).to_pandas()
    assert list(table.columns) == ["time", "lsl_time", "zygomaticus", "corrugator"]
    burst = table.loc[table["zygomaticus"] > 0.5, "time"]
    # Two machines' clocks 312 s and 5000 s apart: the burst is where the event was.
    assert float(burst.mean()) == pytest.approx(recorded.burst_s, abs=0.02)
    assert np.allclose(table["corrugator"], 0.25)
    stimulus = pq.read_table(data / rows["PsychoPy"].path).to_pandas()
    assert stimulus["value"].tolist() == ["stimulus_on"]
    assert float(stimulus["time"].iloc[0]) == pytest.approx(recorded.burst_s, abs=0.005)
    # Importing again replaces the streams rather than adding them twice.
    import_xdf(db_session, recorded.session_id, recorded.path, data)
    db_session.commit()
    assert len(streams_of(db_session, recorded.session_id)) == 2


def test_a_recording_without_this_systems_markers_is_refused(
    db_session: DbSession, tmp_path: Path
) -> None:
    recorded = recorded_session(db_session, tmp_path, session_markers=False)
    with pytest.raises(XdfImportError, match="has no markers of session"):
        import_xdf(db_session, recorded.session_id, recorded.path, tmp_path / "data")
    with pytest.raises(XdfImportError, match="There is no session 999"):
        import_xdf(db_session, 999, recorded.path, tmp_path / "data")
    broken = tmp_path / "broken.xdf"
    broken.write_bytes(b"not an xdf file at all")
    with pytest.raises(XdfImportError, match="is not a readable XDF file"):
        import_xdf(db_session, recorded.session_id, broken, tmp_path / "data")


def test_the_command_imports_and_reports(tmp_path: Path) -> None:
    data = tmp_path / "data"
    data.mkdir()
    url = f"sqlite:///{data / 'chameleons.sqlite3'}"
    upgrade(url)
    engine = build_engine(url)
    with session_scope(build_sessionmaker(engine)) as db:
        recorded = recorded_session(db, tmp_path)
    env = {"CHAMELEONS_DATABASE_URL": url, "CHAMELEONS_DATA_DIR": str(data),
           "CHAMELEONS_SECRET_KEY": secrets.token_urlsafe(32)}  # fmt: skip
    ran = CliRunner().invoke(cli, ["import-xdf", str(recorded.path), "--session",
                                   str(recorded.session_id)], env=env)  # fmt: skip
    assert ran.exit_code == 0, ran.output
    assert f"aligned on {recorded.events} marker(s) of chameleons-" in ran.output
    assert "BioSemi (EMG, 2 channel(s)" in ran.output
    assert "left out (this system's own)" in ran.output
    with build_sessionmaker(engine)() as db:
        assert len(list(db.scalars(select(InstrumentStream)))) == 2
    out = tmp_path / "export"
    exported = CliRunner().invoke(cli, ["export", "--out", str(out), "--instruments"], env=env)
    assert exported.exit_code == 0, exported.output
    assert "2 instrument stream(s) in instruments/" in exported.output
    index = read_csv_rows(out / "instruments" / "streams.csv")
    assert [row["stream"] for row in index] == ["BioSemi", "PsychoPy"]
    emg = pq.read_table(out / "instruments" / index[0]["file"]).to_pandas()
    assert list(emg.columns) == ["time", "lsl_time", "zygomaticus", "corrugator"]
    assert index[0]["channels"] == "zygomaticus|corrugator"
    refused = CliRunner().invoke(cli, ["import-xdf", str(tmp_path / "none.xdf"), "--session",
                                       str(recorded.session_id)], env=env)  # fmt: skip
    engine.dispose()
    assert refused.exit_code == 1
    assert "There is no file" in refused.output
