"""A language whose prompts cannot run a session is refused (real sessions) or warned about
(rehearsals) before the session starts: at registration, at its start, on the phone, and
on the PI's and the wizard's pages; never found out mid-session (issue 28).

The prompts folder is the demo's, except that each actor's Swedish catalogue lacks one
group the study needs (``lunar_water_move_up``) and one recording (``ack_no_2``)."""

from __future__ import annotations

import csv
import io
from pathlib import Path
from types import SimpleNamespace

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, update

from chameleons.backend.models import Session as SessionRow
from chameleons.backend.wizard import console_state, readiness
from chameleons.experiment.study import load_default_study
from chameleons.settings import Settings
from tests.support.bots import ParticipantBot, StaffApi, WizardBot, study_with_plan

PROMPTS = Path(__file__).resolve().parents[3] / "prompts"
ACTORS = ("m1", "m2", "f1", "f2")


def partial_prompts(root: Path) -> Path:
    """The demo prompts, each actor's Swedish without one group and one recording."""
    for actor in ACTORS:
        (root / "sv" / actor).mkdir(parents=True)
        (root / actor).symlink_to(PROMPTS / actor, target_is_directory=True)
        for name in ("audio", "lipsync", "actor.yaml"):
            (root / "sv" / actor / name).symlink_to(PROMPTS / "sv" / actor / name)
        manifest = PROMPTS / "sv" / actor / "manifest.csv"
        with manifest.open(encoding="utf-8", newline="") as handle:
            reader = csv.DictReader(handle)
            rows = [row for row in reader if row["group"] != "lunar_water_move_up"]
            header = list(reader.fieldnames or [])
        for row in rows:
            if row["id"] == "ack_no_2":
                row["audio"] = ""
        out = io.StringIO()
        writer = csv.DictWriter(out, fieldnames=header, lineterminator="\n")
        writer.writeheader()
        writer.writerows(rows)
        (root / "sv" / actor / "manifest.csv").write_text(out.getvalue(), encoding="utf-8")
    return root


@pytest.fixture
def partial(tmp_path: Path) -> Path:
    return partial_prompts(tmp_path / "prompts")


@pytest.fixture
def settings(settings: Settings, partial: Path) -> Settings:
    return settings.model_copy(update={"prompts_dir": partial})


def state_of(root: Path) -> SimpleNamespace:
    return SimpleNamespace(settings=SimpleNamespace(prompts_dir=str(root), data_dir=None))


def test_the_gap_names_the_actor_the_groups_and_the_recordings(partial: Path) -> None:
    state = state_of(partial)
    spec = load_default_study()
    gaps = readiness.language_gaps(state, spec, "sv")
    assert [gap.actor for gap in gaps] == ["m1", "m2", "f1", "f2"]  # the study's order
    gap = gaps[2]
    assert (gap.missing, gap.unrecorded) == (("lunar_water_move_up",), ("ack_no_2",))
    assert gap.needed == 254  # the default study's groups (its 8 robot names, 2 tasks)
    assert gap.sentence() == (
        "actor f1 has no sv prompt for 1 of its 254 prompt groups (lunar_water_move_up) "
        "and 1 sv prompts without a recording (ack_no_2)"
    )
    assert readiness.language_gaps(state, spec, "en") == []
    assert readiness.language_gaps(state, spec, "sv", ["m1"])[0].actor == "m1"


def test_the_demo_catalogue_has_no_gap() -> None:
    assert readiness.study_warnings(state_of(PROMPTS), load_default_study()) == {}


def _refusal(pi: StaffApi, study_id: int, **body: object) -> dict[str, object]:
    response = pi.http.post(
        "/api/sessions",
        json={"study_id": study_id, "booth": "booth-1", **body},
        headers={"X-CSRF-Token": pi.csrf},
    )
    assert response.status_code == 409, response.text
    detail: dict[str, object] = response.json()
    return detail


def test_a_real_session_in_the_language_is_refused_when_registered(pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=12)
    detail = str(_refusal(pi, study_id, language="sv")["detail"])
    assert "The prompt catalogue in sv is incomplete: actor " in detail
    assert "lunar_water_move_up" in detail
    assert detail.endswith("Register the participant in another language.")
    assert pi.get(f"/api/studies/{study_id}/participants") == []  # nothing kept
    assert WizardBot.create(pi, study_id, language="en").snapshot["language"] == "en"
    rehearsal = WizardBot.create(pi, study_id, rehearsal=True, language="sv")
    assert rehearsal.snapshot["language"] == "sv"


def test_the_wizard_page_refuses_it_and_names_the_gap(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=12)
    page = client.get("/wizard")
    assert "Real sessions refused" in page.text
    assert "lunar_water_move_up" in page.text
    form = {"csrf_token": pi.csrf, "study_id": str(study_id), "booth": "booth-1",
            "language": "sv"}  # fmt: skip
    refused = client.post("/wizard/sessions", data=form, follow_redirects=False)
    assert refused.status_code == 409
    assert "Register the participant in another language." in refused.text
    assert pi.get(f"/api/studies/{study_id}/participants") == []


def test_the_pi_sees_the_gap_on_the_study(client: TestClient, pi: StaffApi) -> None:
    study_id = study_with_plan(pi, participants=2)
    study = pi.get(f"/api/studies/{study_id}")
    assert list(study["prompt_gaps"]) == ["sv"]
    assert "actor f1 has no sv prompt" in study["prompt_gaps"]["sv"]
    assert (study["languages"], study["default_language"]) == (["en", "sv"], "en")
    page = client.get("/studies").text
    assert 'class="error prompt-gap" data-language="sv"' in page


def test_the_start_is_refused_when_the_language_changed_to_it(pi: StaffApi, engine: Engine) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    ParticipantBot(pi.http, wizard.token).consent()
    with engine.begin() as db:  # as the phone did before the catalogue lost its prompts
        db.execute(update(SessionRow).where(SessionRow.id == wizard.session_id)
                   .values(language="sv"))  # fmt: skip
    response = pi.http.post(
        f"/api/sessions/{wizard.session_id}/start", json={}, headers={"X-CSRF-Token": pi.csrf}
    )
    assert response.status_code == 409
    assert "A real session in sv cannot run" in response.json()["detail"]
    assert wizard.refresh()["state"] == "pending"


def test_the_phone_is_refused_the_language(client: TestClient, pi: StaffApi) -> None:
    wizard = WizardBot.create(pi, study_with_plan(pi, participants=2))
    phone = ParticipantBot(client, wizard.token)
    response = client.post(f"/api/phone/{wizard.token}/language",
                           json={"client_id": "lang-choice-0001", "language": "sv"})  # fmt: skip
    assert response.status_code == 422
    assert response.json()["detail"] == "This study is not available in that language."
    assert phone.state()["language"] == "en"


def test_the_console_names_the_suggestion_prompt_it_lacks(partial: Path) -> None:
    state = state_of(partial)
    pending = {"accepted": None, "item": "lunar:water", "from_rank": 4, "to_rank": 2}
    interaction = {"position": 1, "state": "negotiation", "actor": "f1", "task": "lunar",
                   "suggestions": [pending], "current_ranking": None,
                   "initial_ranking": ["lunar:oxygen", "lunar:matches", "lunar:pistols",
                                       "lunar:water", "lunar:compass"]}  # fmt: skip
    snapshot = {"language": "sv", "interactions": [interaction]}
    groups, missing = console_state._suggestion_prompts(state, snapshot, 1)
    assert groups == []  # "matches" is outside water's default set: no "above" prompt
    assert missing is not None
    assert "actor f1 has no 'move up' suggestion prompt for lunar:water in sv" in missing
    assert "lunar_water_move_up" in missing
    assert "Do not word it yourself" in missing
    snapshot["language"] = "en"
    groups, missing = console_state._suggestion_prompts(state, snapshot, 1)
    assert (groups, missing) == (["lunar_water_move_up"], None)
