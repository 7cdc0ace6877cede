"""The PI's balance view in Chromium: one coloured map of every counterbalancing constraint
(ideal, largest deviation, status, each count coloured by its distance from the ideal), on
one screen, with the raw count tables one click away."""

from __future__ import annotations

import math
from collections import Counter
from typing import Any

import pytest
from playwright.sync_api import Locator, Page, expect
from sqlalchemy import Engine, select

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.models import Interaction, Participant, Session
from chameleons.experiment.stats.rounding import fmt
from tests.backend.test_auth import add_user
from tests.e2e.pi.test_dashboard_browser import SLOW, log_in
from tests.support.factories import PopulatedStudy, populate
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def study(engine: Engine) -> PopulatedStudy:
    """Six complete sessions and a rehearsal: some counts off their ideal, one constraint
    that cannot hold with six rows (the PI's view must show both)."""
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 6, rehearsals=1)
    add_user(engine, "pia", "correct horse", "pi")
    return data


def _constraints(page: Page, server: LiveServer) -> list[dict[str, Any]]:
    """The balance as the server's JSON reports it (the same login as the page)."""
    answer = page.request.get(f"{server.url}/api/pi/overview", timeout=SLOW)
    assert answer.ok, answer.status
    constraints: list[dict[str, Any]] = answer.json()["balance"]["constraints"]
    return constraints


def _actors_run(engine: Engine) -> Counter[str]:
    """Interactions per actor in the complete non-rehearsal sessions, read from the
    database here (not through the balance code)."""
    with session_scope(build_sessionmaker(engine)) as db:
        actors = db.scalars(
            select(Interaction.actor)
            .join(Session, Session.id == Interaction.session_id)
            .join(Participant, Participant.id == Session.participant_id)
            .where(Session.state == "complete", Participant.is_rehearsal.is_(False))
        ).all()
    return Counter(actors)


def _cells(row: Locator) -> list[tuple[int, str, str]]:
    """(count, colour class, background colour) of each cell of a map row."""
    found: list[tuple[int, str, str]] = row.locator(".cell").evaluate_all(
        """(cells) => cells.map((c) => [Number(c.textContent),
             [...c.classList].find((k) => k.startsWith('dev-')) || '',
             getComputedStyle(c).backgroundColor])"""
    )
    return [tuple(cell) for cell in found]  # type: ignore[misc]


def test_the_balance_map_colours_each_count_by_its_distance_from_the_ideal(
    live_server: LiveServer, page: Page, study: PopulatedStudy, engine: Engine
) -> None:
    page.set_default_timeout(SLOW)
    page.set_viewport_size({"width": 1920, "height": 1080})
    log_in(page, live_server, "/pi")
    balance_map = page.locator("#balance-map")
    expect(balance_map).to_be_visible(timeout=SLOW)
    constraints = _constraints(page, live_server)
    rows = balance_map.locator("tbody tr")
    expect(rows).to_have_count(len(constraints))
    colours: dict[str, set[str]] = {}
    for constraint in constraints:
        row = balance_map.locator(f'tr[data-constraint="{constraint["id"]}"]')
        ideal, deviation, status = (row.locator("td").nth(i) for i in (1, 2, 3))
        expect(ideal).to_have_text(fmt(constraint["ideal"], 2))
        expect(deviation).to_have_text(fmt(constraint["max_deviation"], 2))
        if not constraint["ok"]:  # red, with the verdict on hover
            flag = status.locator(".flag.bad")
            expect(flag).to_have_text(constraint["status"])
            expect(flag).to_have_attribute("title", constraint["verdict"])
        elif constraint["status"] == "minimal":
            expect(status.locator(".flag")).to_have_text("minimal")
        else:
            expect(status.locator(".ok-flag")).to_have_text("ok")
        cells = _cells(row)
        assert sorted(c[0] for c in cells) == sorted(constraint["counts"].values())
        for count, colour_class, background in cells:
            away = min(math.floor(abs(count - constraint["ideal"]) + 1e-9), 3)
            assert colour_class == f"dev-{away}", (constraint["id"], count, colour_class)
            colours.setdefault(colour_class, set()).add(background)
    # One colour per distance, and different distances look different.
    assert all(len(found) == 1 for found in colours.values()), colours
    assert len({next(iter(found)) for found in colours.values()}) == len(colours)
    assert {"dev-0", "dev-1"} <= set(colours)  # this study has counts off the ideal
    assert any(not c["ok"] for c in constraints)  # and a constraint flagged in red
    bad = next(c for c in constraints if not c["ok"])
    expect(balance_map.locator(f'tr[data-constraint="{bad["id"]}"] .flag.bad')).to_be_visible()

    # The counts agree with the interactions in the database, counted here.
    actor_row = balance_map.locator('tr[data-constraint="actor"]')
    assert sorted(c[0] for c in _cells(actor_row)) == sorted(_actors_run(engine).values())

    # Every constraint on one screen: the map fits the window's height.
    box = balance_map.bounding_box()
    assert box is not None
    assert box["height"] <= 1080, box

    # The raw tables are one click away.
    raw = page.locator("details.balance-raw")
    expect(raw).not_to_have_attribute("open", "")
    tables = raw.locator(".balance-table")
    expect(tables.first).to_be_hidden()
    raw.locator("summary").click()
    expect(raw).to_have_attribute("open", "")
    expect(tables).to_have_count(len(constraints))
    for constraint in constraints:
        table = raw.locator(f'.balance-table[data-constraint="{constraint["id"]}"]')
        expect(table).to_be_visible()
        names = table.locator("tbody tr td:first-child").all_inner_texts()
        assert sorted(names) == sorted(constraint["counts"])


def test_a_fresh_study_shows_no_alarm(
    live_server: LiveServer, page: Page, engine: Engine
) -> None:
    """A fresh demo: a study with its plan and nobody run yet. Nothing is uneven, so the
    balance view is calm (it showed four red "uneven" rows with 0 participants)."""
    with session_scope(build_sessionmaker(engine)) as db:
        populate(db, 0)
    add_user(engine, "pia", "correct horse", "pi")
    log_in(page, live_server, "/pi")
    status = page.locator("#balance-status")
    expect(status).to_have_text("Nothing has run yet: the counts fill in as sessions complete.")
    expect(status).to_have_class("ok-flag")
    expect(page.locator("#balance-map")).to_be_visible()
    expect(page.locator("#balance-map tbody tr").first).to_be_visible()
    expect(page.locator("#balance-map .flag.bad")).to_have_count(0)
    expect(page.locator("#balance-map .cell.dev-3")).to_have_count(0)  # no red cell
    assert all(c["ok"] for c in _constraints(page, live_server))
