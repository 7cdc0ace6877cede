"""ELAN: ``chameleons export --format eaf`` writes one .eaf per session that pympi-ling
reads back with the seven tiers; coders' files come back with ``chameleons import-eaf`` and
``chameleons reliability`` reports their agreement per tier (checked against the formulas
worked by hand)."""

from __future__ import annotations

import itertools
import json
import secrets
from datetime import timedelta
from pathlib import Path

import pytest
from click.testing import CliRunner
from pympi.Elan import Eaf
from sqlalchemy import select

from chameleons.backend.db import build_engine, build_sessionmaker, session_scope
from chameleons.backend.instruments.eaf import TIERS
from chameleons.backend.migrate import upgrade
from chameleons.backend.models import Event, Interaction, Participant, Session
from chameleons.cli.main import cli
from tests.support.factories import populate

SMILES = {  # coder -> (start ms, end ms, value) on a tier of their own
    "A": [(1000, 3000, "smile"), (5000, 6000, "frown")],
    "B": [(1000, 3000, "smile"), (5000, 6000, "smile")],
}


@pytest.fixture
def exported(tmp_path: Path) -> tuple[dict[str, str], Path, int, str]:
    data = tmp_path / "data"
    data.mkdir()
    url = f"sqlite:///{data / 'chameleons.sqlite3'}"
    upgrade(url)
    engine = build_engine(url)
    with session_scope(build_sessionmaker(engine)) as db:
        study = populate(db, participants=2)
        session_id = study.session_ids[0]
        session = db.get(Session, session_id)
        assert session is not None
        assert session.started_at is not None
        code = db.scalars(select(Participant.code).where(
            Participant.id == session.participant_id)).one()  # fmt: skip
        first = db.scalars(select(Interaction).where(Interaction.session_id == session_id)
                           .order_by(Interaction.position)).first()  # fmt: skip
        assert first is not None
        at = session.started_at
        for seconds, kind, payload in (
            (60, "prompt.played", {"prompt_id": "greeting", "play_id": "p1"}),
            (60.2, "prompt.speech_start", {"prompt_id": "greeting", "play_id": "p1"}),
            (63.5, "prompt.speech_end", {"prompt_id": "greeting", "play_id": "p1"}),
            (90, "ranking.submitted", {"position": 1, "ranking": ["water", "map"]}),
            (100, "wizard.note", {"text": "P laughed"}),
            (110, "wizard.typed_speech", {"text": "Take your time."}),
        ):
            db.add(Event(study_id=session.study_id, session_id=session_id,
                         interaction_id=first.id, kind=kind, source="test", payload=payload,
                         server_time=at + timedelta(seconds=seconds)))  # fmt: skip
    engine.dispose()
    env = {"CHAMELEONS_DATABASE_URL": url, "CHAMELEONS_DATA_DIR": str(data),
           "CHAMELEONS_SECRET_KEY": secrets.token_urlsafe(32)}  # fmt: skip
    out = tmp_path / "export"
    ran = CliRunner().invoke(cli, ["export", "--out", str(out), "--format", "eaf"], env=env)
    assert ran.exit_code == 0, ran.output
    assert "2 ELAN file(s) in eaf/" in ran.output
    return env, out, session_id, code


def test_each_session_becomes_an_eaf_with_the_seven_tiers(
    exported: tuple[dict[str, str], Path, int, str],
) -> None:
    _env, out, session_id, code = exported
    files = sorted((out / "eaf").glob("*.eaf"))
    assert len(files) == 2
    assert (out / "participants.csv").is_file()  # the usual export is still there
    eaf = Eaf(str(out / "eaf" / f"{code}-session{session_id}.eaf"))
    assert sorted(eaf.get_tier_names()) == sorted(TIERS)
    assert dict(eaf.properties)["chameleons_session_id"] == str(session_id)
    prompts = eaf.get_annotation_data_for_tier("prompts")
    speech = eaf.get_annotation_data_for_tier("robot speech")
    assert [p[2] for p in prompts] == ["greeting"]
    assert [(s[1] - s[0], s[2]) for s in speech] == [(3300, "greeting")]
    assert speech[0][0] - prompts[0][0] == 200
    assert [a[2] for a in eaf.get_annotation_data_for_tier("wizard notes")] == ["P laughed"]
    assert [a[2] for a in eaf.get_annotation_data_for_tier("typed speech")] == ["Take your time."]
    assert [a[2] for a in eaf.get_annotation_data_for_tier("rankings")] == ["water > map"]
    conditions = eaf.get_annotation_data_for_tier("condition")
    assert [c[2].split(": ")[0] for c in conditions] == ["1", "2", "3"]
    assert all(c[1] - c[0] == 12 * 60 * 1000 for c in conditions)
    decisions = [a[2] for a in eaf.get_annotation_data_for_tier("suggestions and decisions")]
    assert len(decisions) == 9
    assert all(d.endswith(("accepted", "declined")) for d in decisions)
    for tier in TIERS:  # ELAN keeps a tier's annotations apart
        spans = sorted(eaf.get_annotation_data_for_tier(tier))
        assert all(a[1] <= b[0] for a, b in itertools.pairwise(spans))


def _coded(source: Path, coder: str, target: Path) -> Path:
    eaf = Eaf(str(source))
    eaf.add_tier("smiles", ann=coder)
    for start, end, value in SMILES[coder]:
        eaf.add_annotation("smiles", start, end, value)
    eaf.to_file(str(target))
    return target


def test_coders_files_come_back_with_their_agreement(
    exported: tuple[dict[str, str], Path, int, str], tmp_path: Path
) -> None:
    env, out, session_id, code = exported
    source = out / "eaf" / f"{code}-session{session_id}.eaf"
    files = [str(_coded(source, coder, tmp_path / f"{coder}.eaf")) for coder in SMILES]
    ran = CliRunner().invoke(cli, ["import-eaf", *files], env=env)
    assert ran.exit_code == 0, ran.output
    assert f"A.eaf: session {session_id}, coder A: smiles 2" in ran.output
    again = CliRunner().invoke(cli, ["import-eaf", files[0]], env=env)  # replaces, not adds
    assert again.exit_code == 0, again.output
    report = CliRunner().invoke(cli, ["reliability", "--format", "json"], env=env)
    assert report.exit_code == 0, report.output
    (tier,) = json.loads(report.output)["tiers"]
    assert tier["tier"] == "smiles"
    assert tier["coders"] == ["A", "B"]
    assert tier["units"] == 50  # 1000 ms to 6000 ms in 100 ms units
    # 40 of 50 units agree; A: 40 % none, 20 % frown, 40 % smile; B: 40 % none, 60 % smile.
    assert tier["cohen_kappa"]["A|B"] == pytest.approx((0.8 - 0.4) / 0.6, abs=1e-4)
    assert tier["fleiss_kappa"] == pytest.approx((0.8 - 0.42) / 0.58, abs=1e-4)
    assert tier["krippendorff_alpha"] == pytest.approx(1 - 0.2 / (1 - 4100 / 9900), abs=1e-4)
    text = CliRunner().invoke(cli, ["reliability"], env=env)
    assert (
        "smiles: 2 coders, 1 session(s), 50 units of 100 ms; Cohen's kappa A vs B 0.667"
        in text.output
    )
    export = CliRunner().invoke(cli, ["export", "--out", str(out), "--format", "eaf"], env=env)
    assert export.exit_code == 0, export.output
    assert (
        (out / "eaf" / "reliability.csv")
        .read_text()
        .splitlines()[1]
        .startswith("smiles,A|B,1,50,A|B,0.6667")
    )


def test_a_file_that_is_not_elan_is_refused(
    exported: tuple[dict[str, str], Path, int, str], tmp_path: Path
) -> None:
    env, _out, _session_id, _code = exported
    broken = tmp_path / "broken.eaf"
    broken.write_text("<not-elan>")
    ran = CliRunner().invoke(cli, ["import-eaf", str(broken), "--coder", "A"], env=env)
    assert ran.exit_code == 1
    assert "broken.eaf is not a readable ELAN file" in ran.output
    none = CliRunner().invoke(cli, ["reliability"], env=env)
    assert "No tier was coded by two or more coders" in none.output
