"""Arabic (right to left) and Japanese (no spaces to break at) on a 390x844 phone: the
pages say their language and direction, and the consent page, a questionnaire and the
ranking show long test strings without sideways scrolling or clipped text. Screenshots go
to ``test-results/phone-<lang>-<view>.png`` for a person to look at."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import Browser, Page, expect
from sqlalchemy import Engine

from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import PASSWORD, StaffApi, WizardBot, add_staff, study_with_plan
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
RESULTS = Path(__file__).resolve().parents[3] / "test-results"
TEXTS = {
    "ar": (
        "مرحبا بك في هذه الدراسة عن الروبوتات. هذا نص تجريبي طويل للتأكد من أن الصفحة تُعرض"
        " من اليمين إلى اليسار دون أن يُقص أي جزء منه على شاشة الهاتف الصغيرة.",
        "جهاز إرسال واستقبال يعمل بالطاقة الشمسية مع هوائي طويل",
    ),
    "ja": (
        "ようこそ。これは電話の小さな画面で日本語の長い文章が途中で切れることなく正しく折り返され"
        "て表示されることを確認するための試験用の文字列です。",
        "太陽電池式の超短波送受信機と長いアンテナ一式(予備電池付き)",
    ),
}
# Every element's box must stay inside the viewport, and nothing may hide overflowing text.
CLIPPED = """() => {
  const out = [];
  for (const el of document.querySelectorAll("main *")) {
    const box = el.getBoundingClientRect();
    if (!box.width || getComputedStyle(el).position === "absolute") continue;
    const tag = el.outerHTML.slice(0, 80);
    if (box.left < -1 || box.right > window.innerWidth + 1) out.push("outside: " + tag);
    const hides = getComputedStyle(el).overflowX !== "visible" && el.tagName !== "TEXTAREA";
    if (hides && el.scrollWidth > el.clientWidth + 1) out.push("clipped: " + tag);
  }
  return out;
}"""


def translated(english: str, language: str, key: str) -> str:
    sentence, item = TEXTS[language]
    if key == "name":
        return item
    return sentence if len(english) > 25 else sentence.split("。")[0].split(".")[0][:40]


def localize(node: Any, language: str, key: str = "") -> Any:
    """The default study with every Swedish text replaced by a test string in ``language``."""
    if isinstance(node, dict):
        if set(node) == {"en", "sv"}:
            return {"en": node["en"], language: translated(node["en"], language, key)}
        return {k: localize(v, language, str(k)) for k, v in node.items()}
    if isinstance(node, list):
        return [localize(value, language, key) for value in node]
    return node


@pytest.fixture
def server(app: Any) -> Iterator[LiveServer]:
    live = LiveServer(app).start()
    yield live
    live.stop()


def check_fits(page: Page, language: str, view: str) -> None:
    assert page.evaluate("document.documentElement.scrollWidth - window.innerWidth") <= 0
    assert page.evaluate(CLIPPED) == []
    RESULTS.mkdir(exist_ok=True)
    shot = RESULTS / f"phone-{language}-{view}.png"
    page.screenshot(path=str(shot), full_page=True)
    assert shot.stat().st_size > 10_000


@pytest.mark.parametrize("language", ["ar", "ja"])
def test_right_to_left_and_cjk_text_fit_the_phone(
    server: LiveServer, engine: Engine, browser: Browser, language: str
) -> None:
    add_staff(engine, "pia", "pi")
    http = httpx.Client(base_url=server.url, limits=httpx.Limits(max_keepalive_connections=0))
    pi = StaffApi(http).login("pia", PASSWORD)
    document = localize(default_document(), language)
    document["languages"] = ["en", language]
    wizard = WizardBot.create(pi, study_with_plan(pi, yaml=study_yaml(document)), language=language)
    sentence, item = TEXTS[language]
    context = browser.new_context(viewport={"width": 390, "height": 844}, is_mobile=True)
    try:
        page = context.new_page()
        page.goto(server.url + wizard.phone_path)
        html = page.locator("html")
        expect(html).to_have_attribute("lang", language)
        expect(html).to_have_attribute("dir", "rtl" if language == "ar" else "ltr")
        expect(page.locator("#app p").first).to_have_text(sentence)
        direction = page.locator("#app h1").evaluate("h => getComputedStyle(h).direction")
        assert direction == ("rtl" if language == "ar" else "ltr")
        check_fits(page, language, "consent")
        page.locator("#consent-agree").click()
        expect(page.locator("form#questionnaire")).to_be_visible()
        check_fits(page, language, "questionnaire")
        page.locator("form#questionnaire button[type=submit]").click()
        expect(page.locator("#app")).to_have_attribute("data-view", "welcome")
        wizard.start(prepare=False)
        wizard.advance(1, "discussion")
        wizard.advance(1, "ranking")
        expect(page.locator("#ranking-list .name").first).to_have_text(item)
        check_fits(page, language, "ranking")
    finally:
        context.close()
        http.close()
