"""The PI dashboard pages over HTTP: overview, session detail, recordings, access control."""

from __future__ import annotations

import random
import re
from typing import Any

from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from tests.backend.test_auth import add_user, login
from tests.support.bots import run_session, staff_api, study_with_plan
from tests.support.factories import PopulatedStudy, add_event, populate


def _populate(engine: Engine, settings: Any, **kwargs: Any) -> PopulatedStudy:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, recordings_dir=settings.data_dir / "recordings", **kwargs)
    return data


def test_overview_shows_progress_sessions_and_balance(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    data = _populate(engine, settings, participants=3, rehearsals=1, free_rows=2)
    with session_scope(build_sessionmaker(engine)) as db:
        add_event(db, data.session_ids[1], "worker.outage", {"reason": "crashed"}, 2)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get("/pi")
    assert page.status_code == 200
    for code in data.codes:
        assert f'data-participant="{code}"' in page.text
    assert 'data-stat="free">3<' in page.text  # the rehearsal only borrowed its row
    assert "rehearsal</span>" in page.text
    assert 'data-constraint="condition_position"' in page.text
    api = client.get("/api/pi/overview").json()
    assert api["progress"]["rows"] == 6
    assert api["balance"]["participants"] == 3
    flagged = {s["participant"]: s["flags"] for s in api["sessions"]}
    assert flagged["P001"] == []
    assert [f["kind"] for f in flagged["P002"]] == ["outage"]
    with_rehearsals = client.get("/api/pi/overview", params={"include_rehearsal": True}).json()
    assert with_rehearsals["balance"]["participants"] == 4


def test_session_detail_and_recording_download(
    client: TestClient, engine: Engine, settings: Any
) -> None:
    data = _populate(engine, settings, participants=1)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get(f"/pi/sessions/{data.session_ids[0]}")
    assert page.status_code == 200
    text = page.text
    assert text.count('class="card interaction"') == 3
    assert text.count('<tr><td class="num">1</td><td>') >= 3  # suggestions listed
    assert "Error score" in text
    assert "session_started" in text  # the timeline
    assert "Answer to differences by P001" in text  # final questionnaire
    first = text.index('href="/pi/recordings/') + len('href="/pi/recordings/')
    recording_id = text[first : text.index('"', first)]
    download = client.get(f"/pi/recordings/{recording_id}")
    assert download.status_code == 200
    assert download.content in {p.read_bytes() for p in data.recording_paths}
    assert client.get("/pi/sessions/999").status_code == 404
    assert client.get("/pi/recordings/999").status_code == 404


def test_pages_need_a_pi(client: TestClient, engine: Engine, settings: Any) -> None:
    _populate(engine, settings, participants=1)
    assert client.get("/pi", follow_redirects=False).headers["location"] == "/login?next=/pi"
    assert client.get("/api/pi/overview").status_code == 401
    add_user(engine, "wiz", "right password", "wizard")
    login(client, "wiz", "right password")
    for url in ("/pi", "/pi/sessions/1", "/pi/recordings/1", "/pi/export", "/api/pi/overview"):
        assert client.get(url).status_code == 403, url


def test_without_a_study_the_overview_says_so(client: TestClient, engine: Engine) -> None:
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    response = client.get("/pi")
    assert response.status_code == 404
    assert "there is no study yet" in response.text
    assert 'href="/studies"' in response.text


def test_several_studies_can_be_switched(client: TestClient, engine: Engine) -> None:
    from chameleons.experiment.study import load_default_study

    with session_scope(build_sessionmaker(engine)) as db:
        first = populate(db, 1)
        second = populate(db, 2, spec=load_default_study(), name="Replication")
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    newest = client.get("/pi/analysis")
    assert f"Study {second.study_id}: Replication" in newest.text
    assert f'href="/pi/analysis?study={first.study_id}"' in newest.text
    older = client.get("/pi", params={"study": first.study_id}).text
    assert 'data-participant="P002"' not in older
    assert client.get("/pi", params={"study": 999}).status_code == 404


def test_the_balance_shows_as_one_coloured_map_with_the_raw_tables_a_click_away(
    client: TestClient, engine: Engine
) -> None:
    pi = staff_api(client, engine, "pi")
    study_id = study_with_plan(pi, participants=6)
    for n in range(2):
        run_session(pi, client, study_id, random.Random(n))
    page = client.get("/pi", params={"study": study_id}).text
    balance_map = page.split('id="balance-map"', 1)[1].split("</table>", 1)[0]
    constraints = re.findall(r'<tr data-constraint="([^"]+)"', balance_map)
    assert "condition_position" in constraints
    assert len(constraints) == len(set(constraints)) >= 10
    cells = re.findall(r'<span class="cell dev-(\d)" title="([^"]+)">(\d+)</span>', balance_map)
    assert cells
    for level, title, count in cells:
        ideal = float(title.rsplit("ideal ", 1)[1])
        assert int(level) == min(int(abs(int(count) - ideal)), 3), title
    assert '<details class="balance-raw">' in page  # the named counts, one click away
