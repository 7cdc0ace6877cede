"""The PI's session page shows each interaction's synchrony (values, the copy check, the
plot with its surrogate band, or why there is none), and a failed copy check is a flag."""

from __future__ import annotations

from pathlib import Path
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Interaction, InteractionSynchrony
from chameleons.backend.synchrony import repository, service
from tests.backend.synchrony.recorded import recorded_study
from tests.backend.synchrony.test_service import PARAMS
from tests.backend.test_auth import add_user, login


def _study(engine: Engine, data_dir: Path) -> tuple[int, dict[str, int]]:
    with session_scope(build_sessionmaker(engine)) as db:
        study = recorded_study(db, data_dir, participants=1)
        for interaction_id in repository.interactions_of(db, study.study_id):
            service.compute(db, interaction_id, data_dir, PARAMS)
        conditions = {i.condition: i.id for i in db.scalars(select(Interaction))}
        return study.session_ids[0], conditions


def test_the_session_page_shows_synchrony_and_its_plot(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    session_id, ids = _study(engine, Path(settings.data_dir))
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get(f"/pi/sessions/{session_id}")
    assert page.status_code == 200
    assert 'data-check="ok">copy check ok' in page.text
    assert "Robot follows participant: <strong>4.00 s</strong>" in page.text
    assert 'data-reason="robot_still">No values: The robot&#39;s head and face' in page.text
    assert f'src="/pi/interactions/{ids["copy"]}/synchrony.svg"' in page.text
    assert f'src="/pi/interactions/{ids["still"]}/synchrony.svg"' not in page.text
    plot = client.get(f"/pi/interactions/{ids['copy']}/synchrony.svg")
    assert plot.status_code == 200
    assert plot.headers["content-type"] == "image/svg+xml"
    assert plot.text.lstrip().startswith("<?xml")
    assert "configured delay 4 s" in plot.text
    assert client.get(f"/pi/interactions/{ids['still']}/synchrony.svg").status_code == 404


def test_a_failed_copy_check_is_a_session_flag(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    session_id, ids = _study(engine, Path(settings.data_dir))
    with session_scope(build_sessionmaker(engine)) as db:
        row = db.scalars(select(InteractionSynchrony).where(
            InteractionSynchrony.interaction_id == ids["copy"])).one()  # fmt: skip
        row.check, row.check_reason = "failed", "The robot followed at 0.50 s, not at 4 s."
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get(f"/pi/sessions/{session_id}")
    assert 'data-flag="synchrony">manipulation check failed' in page.text
    assert "the copy check failed. The robot followed at 0.50 s" in page.text
    overview = client.get("/api/pi/overview").json()
    kinds = [f["kind"] for s in overview["sessions"] for f in s["flags"]]
    assert "synchrony" in kinds


def test_the_plot_needs_a_pi(client: TestClient, engine: Engine, settings: Any) -> None:
    _, ids = _study(engine, Path(settings.data_dir))
    response = client.get(f"/pi/interactions/{ids['copy']}/synchrony.svg",
                          follow_redirects=False)  # fmt: skip
    assert response.status_code in {303, 401, 403}
