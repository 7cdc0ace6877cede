"""The PI sees the other instruments under the timeline in Chromium, on a desk screen and
on a phone: each imported stream's plot loads and fits, and the page never scrolls
sideways."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Browser, expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.instruments.xdf_import import import_xdf
from tests.backend.test_auth import add_user
from tests.e2e.pi.screens import SCREENS, pi_page
from tests.e2e.pi.test_dashboard_browser import SLOW
from tests.instruments.xdf_session import recorded_session
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def session_id(engine: Engine, settings: Any, tmp_path: Path) -> int:
    with session_scope(build_sessionmaker(engine)) as db:
        recorded = recorded_session(db, tmp_path)
        import_xdf(db, recorded.session_id, recorded.path, Path(settings.data_dir))
    add_user(engine, "pia", "correct horse", "pi")
    return recorded.session_id


@pytest.mark.parametrize("screen", sorted(SCREENS))
def test_the_pi_sees_the_instruments_under_the_timeline(
    live_server: LiveServer, browser: Browser, session_id: int, screen: str
) -> None:
    width = SCREENS[screen][0]
    context, page = pi_page(browser, f"{live_server.url}/pi/sessions/{session_id}", screen)
    emg = page.locator('#instruments figure[data-stream="BioSemi"]')
    expect(emg).to_contain_text("BioSemi · EMG · 2 channels", timeout=SLOW)
    for plot in page.locator("#instruments img.instrument-plot").all():
        plot.scroll_into_view_if_needed()
        page.wait_for_function(
            "img => img.complete && img.naturalWidth > 0", arg=plot.element_handle(), timeout=SLOW
        )
        box = plot.bounding_box()
        assert box is not None
        assert box["x"] + box["width"] <= width  # the plot fits the screen
    assert page.locator("#instruments img.instrument-plot").count() == 2
    assert page.evaluate("document.documentElement.scrollWidth") <= width
    context.close()
