"""`chameleons rehearse --language sv`: a whole session in Swedish through the embedded
system (phone, prompts, robot), exported with the participant's language in the columns."""

from __future__ import annotations

import csv
import hashlib
import json
import secrets
from pathlib import Path

import pytest
from click.testing import CliRunner

from chameleons.backend.db import build_engine, build_sessionmaker
from chameleons.backend.export.service import ExportRequest, export_to_directory
from chameleons.cli.main import cli
from chameleons.prompts import load_catalogue
from chameleons.rehearsal.embedded import embedded_system
from chameleons.rehearsal.runner import Options, RehearsalError, Summary, rehearse
from chameleons.settings import Settings

pytestmark = pytest.mark.slow
PROMPTS = Path(__file__).resolve().parents[2] / "prompts"


def rows(path: Path) -> list[dict[str, str]]:
    with path.open(encoding="utf-8", newline="") as handle:
        return list(csv.DictReader(handle))


def test_a_whole_rehearsal_session_in_swedish(tmp_path: Path) -> None:
    data = tmp_path / "data"
    args = ["rehearse", "-n", "1", "--script", "full", "--seed", "3", "--language", "sv"]
    result = CliRunner().invoke(cli, args, env={"CHAMELEONS_DATA_DIR": str(data)})
    assert result.exit_code == 0, result.output
    assert "Rehearsed 1 session (1 participant, R001)" in result.output
    assert "language sv." in result.output
    settings = Settings(data_dir=data, _env_file=None)
    engine = build_engine(settings.effective_database_url)
    out = tmp_path / "export"
    try:
        with build_sessionmaker(engine)() as db:
            export_to_directory(db, ExportRequest(include_rehearsal=True), out)
    finally:
        engine.dispose()
    (participant,) = rows(out / "participants.csv")
    assert (participant["participant"], participant["session_state"]) == ("R001", "complete")
    assert participant["language"] == "sv"
    answers = rows(out / "questionnaire.csv")
    assert len(answers) > 40
    assert {a["language"] for a in answers} == {"sv"}
    assert {a["version"] for a in answers if a["questionnaire"] == "trust"} == {"rau2009-v1"}
    # Every prompt the wizard played was one of the actor's Swedish recordings.
    events = rows(out / "events.csv")
    played = [json.loads(e["payload"]) for e in events if e["kind"] == "prompt.played"]
    assert len(played) >= 5
    swedish = {p.text for actor in ("m1", "m2", "f1", "f2")
               for p in load_catalogue(PROMPTS / "sv" / actor).prompts}  # fmt: skip
    assert {p["text"] for p in played} <= swedish
    book = {(r["table"], r["column"]) for r in rows(out / "codebook.csv")}
    assert {("participants", "language"), ("questionnaire", "language")} <= book


def test_a_language_the_study_does_not_have_is_refused(tmp_path: Path) -> None:
    settings = Settings(
        data_dir=tmp_path / "data", secret_key=secrets.token_urlsafe(32), _env_file=None
    )
    with (
        embedded_system(settings, simulate_face=False) as target,
        pytest.raises(RehearsalError) as refused,
    ):
        rehearse(target, Options(1, script="silent", display=False, language="de"))
    assert str(refused.value) == (
        "Cannot open a session: The study has no language 'de' (its languages: en, sv)."
    )


def _rehearse(tmp_path: Path, language: str) -> Summary:
    settings = Settings(
        data_dir=tmp_path / language, secret_key=secrets.token_urlsafe(32), _env_file=None
    )
    with embedded_system(settings, simulate_face=False) as target:
        return rehearse(target, Options(1, seed=5, script="full", language=language))


def _sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


def test_a_swedish_rehearsal_voices_as_many_prompts_as_an_english_one(tmp_path: Path) -> None:
    """The same participant (seed) in English and in Swedish: every prompt the wizard
    plays in English has a Swedish one, and the display is served the Swedish file."""
    english, swedish = _rehearse(tmp_path, "en"), _rehearse(tmp_path, "sv")
    assert english.warnings == swedish.warnings == []
    assert english.tally.prompts_played > 40
    assert swedish.tally.prompts_played == english.tally.prompts_played
    assert swedish.tally.prompts_not_sent == english.tally.prompts_not_sent == 0
    assert (swedish.unloaded, english.unloaded) == ([], [])
    assert swedish.voiced == english.voiced == english.tally.prompts_played
    assert len(swedish.fetched) == swedish.voiced
    for prompt_id, path, digest in swedish.fetched:
        actor, name = path.split("/")[3], path.rsplit("/", 1)[1]
        assert digest == _sha256(PROMPTS / "sv" / actor / "audio" / name), prompt_id
        assert digest != _sha256(PROMPTS / actor / "audio" / name), prompt_id
    for _prompt_id, path, digest in english.fetched:
        assert digest == _sha256(PROMPTS / path.split("/")[3] / "audio" / path.rsplit("/")[-1])
