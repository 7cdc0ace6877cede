"""The PI sees the synchrony of the faces in Chromium, on a desk screen and on a phone: the
session page's plot with its surrogate band loads and fits, and the analysis page loads its
synchrony section beside the models."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.synchrony import repository, service
from tests.backend.synchrony.recorded import recorded_study
from tests.backend.synchrony.test_service import PARAMS
from tests.backend.test_auth import add_user
from tests.e2e.pi.screens import SCREENS, pi_page
from tests.e2e.pi.test_dashboard_browser import SLOW
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def session_id(engine: Engine, settings: Any) -> int:
    data_dir = Path(settings.data_dir)
    with session_scope(build_sessionmaker(engine)) as db:
        study = recorded_study(db, data_dir, participants=2)
        for interaction_id in repository.interactions_of(db, study.study_id):
            service.compute(db, interaction_id, data_dir, PARAMS)
    add_user(engine, "pia", "correct horse", "pi")
    return study.session_ids[0]


@pytest.mark.parametrize("screen", sorted(SCREENS))
def test_the_pi_sees_synchrony_on_a_desk_and_a_phone(
    live_server: LiveServer, browser: Browser, session_id: int, screen: str
) -> None:
    width = SCREENS[screen][0]
    context, page = pi_page(browser, f"{live_server.url}/pi/sessions/{session_id}", screen)
    copy = page.locator(".synchrony:has([data-check])")
    expect(copy).to_contain_text("copy check ok", timeout=SLOW)
    plot = copy.locator("img.synchrony-plot")
    plot.scroll_into_view_if_needed()
    page.wait_for_function(
        "img => img.complete && img.naturalWidth > 0", arg=plot.element_handle(), timeout=SLOW
    )
    box = plot.bounding_box()
    assert box is not None
    assert box["x"] + box["width"] <= width  # the plot fits the screen
    # Nothing on the page (the rankings and suggestions tables) makes the whole page scroll
    # sideways: a wide table scrolls inside its own box.
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    page.goto(f"{live_server.url}/pi/analysis")
    section = page.locator("#synchrony-section[data-loaded='true']")
    expect(section.locator("#synchrony-by-condition")).to_be_visible(timeout=SLOW)
    expect(section.locator('tr[data-condition="copy"]')).to_contain_text("ok 2")
    context.close()
