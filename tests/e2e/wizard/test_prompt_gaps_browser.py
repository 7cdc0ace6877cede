"""The PI's study list and the wizard's session picker name a language whose prompts cannot
run a session (and the synthetic natural clip), readable at 1280x720 and on a 390x844 phone:
the sentences wrap (long prompt group names too) and the picker needs no sideways scrolling.
(The study list's table itself is wider than a phone, with or without them.)"""

from __future__ import annotations

from pathlib import Path

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.settings import Settings
from tests.backend.wizard.test_readiness import partial_prompts
from tests.e2e.wizard.conftest import log_in
from tests.support.bots import StaffApi, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser


@pytest.fixture
def settings(settings: Settings, tmp_path: Path) -> Settings:
    return settings.model_copy(update={"prompts_dir": partial_prompts(tmp_path / "prompts")})


def fits(page: Page) -> bool:
    return bool(page.evaluate("document.documentElement.scrollWidth <= window.innerWidth"))


def wraps(page: Page, selector: str) -> bool:
    """Every element of ``selector`` shows its text without overflowing its own box."""
    return bool(page.evaluate(
        f"Array.from(document.querySelectorAll('{selector}'))"
        ".every(e => e.scrollWidth <= e.clientWidth)"
    ))  # fmt: skip


@pytest.mark.parametrize("size", [(1280, 720), (390, 844)], ids=["desktop", "phone"])
def test_the_gaps_are_shown_before_anyone_registers(
    live_server: LiveServer, staff: StaffApi, page: Page, engine: Engine, size: tuple[int, int]
) -> None:
    study_with_plan(staff, participants=2)
    page.set_viewport_size({"width": size[0], "height": size[1]})
    log_in(page, live_server.url, engine, "/studies")
    page.wait_for_url("**/studies")
    gap = page.locator(".prompt-gap[data-language=sv]")
    expect(gap).to_be_visible()
    expect(gap).to_contain_text("Real sessions in sv are refused")
    expect(gap).to_contain_text("lunar_water_move_up")
    expect(page.locator(".natural-clip-warning")).to_contain_text("synthetic demo clip")
    assert wraps(page, ".prompt-gap, .natural-clip-warning")
    page.goto(f"{live_server.url}/wizard")
    expect(page.locator(".prompt-gap")).to_contain_text("Real sessions refused")
    expect(page.locator(".natural-clip-warning")).to_be_visible()
    assert wraps(page, ".prompt-gap, .natural-clip-warning")
    assert fits(page)
