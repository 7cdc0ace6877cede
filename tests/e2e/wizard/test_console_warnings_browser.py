"""The console warns on a real participant's natural interaction, before the robot is set,
that the study replays the synthetic demo clip (issue 28), on the prompt board at 1280x720."""

from __future__ import annotations

import pytest
from playwright.sync_api import expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser


def test_the_prompt_board_warns_about_the_synthetic_natural_clip(console: Console) -> None:
    console.wizard.switch_condition("natural", 1)
    page = console.page
    page.set_viewport_size({"width": 1280, "height": 720})
    page.goto(console.url)
    warning = page.locator(".wz-natural-warning")
    expect(warning).to_have_count(1)
    expect(warning).to_be_visible()
    expect(warning).to_contain_text("replays the synthetic demo clip demo-natural")
    expect(page.locator("#prompt-language-warning")).to_have_count(0)  # English: complete
