"""Studies from YAML, their plan (generated, extended), participants on plan rows."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Event, Participant
from chameleons.backend.studies import service
from chameleons.experiment.study import default_study_path, load_default_study
from tests.backend.sessions.conftest import refused
from tests.experiment.study_files import default_document, laughs, study_yaml, with_german
from tests.support.bots import ApiError, StaffApi, WizardBot, staff_api
from tests.support.catalogues import MakeCatalogues, filler


@pytest.fixture
def pi(client: TestClient, engine: Engine) -> StaffApi:
    return staff_api(client, engine, "pi")


def test_the_pi_creates_the_default_study_with_its_snapshot_and_hash(pi: StaffApi) -> None:
    study = pi.post("/api/studies", {"plan_seed": 3})
    spec = load_default_study()
    assert study["config_hash"] == spec.content_hash
    assert study["plan_seed"] == 3
    assert (study["plan_rows"], study["participants"]) == (0, 0)
    assert "already exists" in refused(lambda: pi.post("/api/studies", {}), 409)
    assert [s["id"] for s in pi.get("/api/studies")] == [study["id"]]


def test_a_study_yaml_with_problems_is_refused_with_every_problem(pi: StaffApi) -> None:
    text = default_study_path().read_text().replace("expert_rank: 2\n", "expert_rank: 1\n", 1)
    detail = refused(lambda: pi.post("/api/studies", {"yaml": text}), 422)
    assert "expert rank" in detail or "problems" in detail
    other = default_study_path().read_text().replace("name: Mechanical Chameleons", "name: Pilot")
    assert pi.post("/api/studies", {"yaml": other})["name"] == "Pilot"


@pytest.mark.parametrize(
    ("extra", "problem"),
    [
        (laughs(9), "too large: the document stands for more than"),  # 387,420,489 values
        ("loop: &loop [1, *loop]\n", "too large: an alias refers to a node that contains it"),
        ("deep: " + "[" * 5000 + "]" * 5000 + "\n", "nested too deeply"),  # was a 500
    ],
)
def test_a_study_yaml_that_expands_without_bound_is_a_422_at_once(
    pi: StaffApi, extra: str, problem: str
) -> None:
    text = default_study_path().read_text() + extra
    with pytest.raises(ApiError) as refusal:
        pi.post("/api/studies", {"yaml": text})
    assert refusal.value.status == 422
    [found] = refusal.value.detail["problems"]
    assert found.startswith(problem), found
    assert pi.get("/api/studies") == []


def test_the_plan_is_generated_then_extended_keeping_its_rows(pi: StaffApi) -> None:
    study = pi.post("/api/studies", {"plan_seed": 5})
    plan_path = f"/api/studies/{study['id']}/plan"
    assert pi.post(plan_path, {"participants": 12})["plan_rows"] == 12
    first = pi.get(plan_path)
    assert [row["row_number"] for row in first] == list(range(1, 13))
    assert {i["position"] for i in first[0]["interactions"]} == {1, 2, 3}
    assert pi.post(plan_path, {"participants": 14})["plan_rows"] == 14
    extended = pi.get(plan_path)
    assert [r["interactions"] for r in extended[:12]] == [r["interactions"] for r in first]
    assert "ask for more than 14" in refused(lambda: pi.post(plan_path, {"participants": 14}), 409)
    message = refused(lambda: pi.post(plan_path, {"participants": 20, "seed": 6}), 409)
    assert "another seed" in message


def test_participants_get_codes_and_the_next_free_row_replacements_first(
    pi: StaffApi, engine: Engine
) -> None:
    study = pi.post("/api/studies", {"plan_seed": 5})
    pi.post(f"/api/studies/{study['id']}/plan", {"participants": 3})
    people = f"/api/studies/{study['id']}/participants"
    registered = [pi.post(people, {}) for _ in range(3)]
    assert [(p["code"], p["row_number"]) for p in registered] == [
        ("P001", 1),
        ("P002", 2),
        ("P003", 3),
    ]
    assert "All 3 plan rows are taken" in refused(lambda: pi.post(people, {}), 409)
    rehearsal = pi.post(people, {"rehearsal": True})
    assert (rehearsal["code"], rehearsal["row_number"]) == ("R001", None)
    with session_scope(build_sessionmaker(engine)) as db:  # the PI withdraws P002
        withdrawn = db.scalars(select(Participant).where(Participant.code == "P002")).one()
        service.release_plan_row(db, withdrawn)
        db.delete(withdrawn)
    replacement = pi.post(people, {})
    assert (replacement["code"], replacement["row_number"]) == ("P004", 2)
    with build_sessionmaker(engine)() as db:
        kinds = [e.kind for e in db.scalars(select(Event).order_by(Event.id))]
        payloads = [e.payload for e in db.scalars(select(Event).order_by(Event.id))]
    assert kinds.count("participant.registered") == 5
    assert "plan_row.released" in kinds
    assert payloads[-1] == {
        "code": "P004",
        "row_number": 2,
        "replacement": True,
        "rehearsal": False,
    }


def test_a_session_follows_its_plan_row(pi: StaffApi) -> None:
    study = pi.post("/api/studies", {"plan_seed": 5})
    pi.post(f"/api/studies/{study['id']}/plan", {"participants": 2})
    row = pi.get(f"/api/studies/{study['id']}/plan")[0]
    wizard = WizardBot.create(pi, study["id"])
    assert wizard.snapshot["participant"]["code"] == "P001"
    for planned, interaction in zip(
        row["interactions"], wizard.snapshot["interactions"], strict=True
    ):
        for key in ("position", "actor", "face", "robot_name", "task", "item_set"):
            assert interaction[key] == planned[key]
        assert interaction["planned_condition"] == planned["condition"]
        assert interaction["presented_order"] == planned["item_order"]
    again = {"study_id": study["id"], "participant_code": "P001"}
    assert "already has session" in refused(lambda: pi.post("/api/sessions", again), 409)
    unknown = {"study_id": study["id"], "participant_code": "P404"}
    assert "no participant 'P404'" in refused(lambda: pi.post("/api/sessions", unknown), 404)


def test_the_pi_pages_create_a_study_and_its_plan(client: TestClient, pi: StaffApi) -> None:
    page = client.get("/studies")
    assert page.status_code == 200
    assert "Create a study" in page.text
    created = client.post("/studies", data={"csrf_token": pi.csrf}, follow_redirects=False)
    assert created.status_code == 303
    study = pi.get("/api/studies")[0]
    planned = client.post(
        f"/studies/{study['id']}/plan",
        data={"csrf_token": pi.csrf, "participants": "12"},
        follow_redirects=False,
    )
    assert planned.status_code == 303
    assert pi.get(f"/api/studies/{study['id']}")["plan_rows"] == 12
    again = client.post("/studies", data={"csrf_token": pi.csrf})
    assert again.status_code == 409
    assert "already exists" in again.text


def test_a_study_in_a_language_the_phone_cannot_speak_is_refused_at_upload(
    pi: StaffApi, extra_catalogues: MakeCatalogues
) -> None:
    text = study_yaml(with_german(default_document()))
    with pytest.raises(ApiError) as caught:
        pi.post("/api/studies", {"yaml": text})
    assert caught.value.status == 422
    assert isinstance(caught.value.detail, dict)
    [problem] = caught.value.detail["problems"]
    assert problem.startswith("languages[2]: 'de' has no translation of the phone's own texts")
    assert "make i18n-extract" in problem

    # With a German catalogue lacking one text, the study is created with a warning.
    german = filler("Deutsch")
    extra_catalogues({"de": lambda m: "" if m == "Connected" else german(m)})
    study = pi.post("/api/studies", {"yaml": text})
    assert study["name"] == "Mechanical Chameleons"
    assert any(
        w.startswith("languages[2]: 1 of the phone's own texts have no de translation")
        for w in study["warnings"]
    ), study["warnings"]
