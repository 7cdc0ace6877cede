"""Arabic (right to left) and Japanese (no spaces to break at) on a 390x844 phone: the
pages say their language and direction, and the consent page, a questionnaire and the
ranking show long test strings without sideways scrolling or clipped text, every character
drawn by a real glyph (not the empty box a missing font shows). Screenshots go to
``test-results/phone-<lang>-<view>.png`` for a person to look at.

The phone's own texts need a catalogue in each declared language, so the test writes
stand-in ones (a fixed phrase in the language) beside the shipped catalogues.
"""

from __future__ import annotations

import os
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest
from playwright.sync_api import Browser, Page, Playwright, expect
from sqlalchemy import Engine

from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import PASSWORD, StaffApi, WizardBot, add_staff, study_with_plan
from tests.support.browser import CHROMIUM_ARGS, chromium_path
from tests.support.catalogues import MakeCatalogues, filler
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
# The phone's own texts: a stand-in phrase ("test text") in the language.
PHONE_TEXTS = {"ar": "نص تجريبي", "ja": "試験用の文字"}
FONTS = "install fonts for it (Debian: fonts-noto-core, fonts-noto-cjk; .ci/run does)"
# Which visible characters no installed font draws. Each is drawn alone on a canvas in its
# element's font; a character no font has comes out as the font's "missing glyph" box
# (.notdef), so it draws exactly like U+0378, which is unassigned and in no font. The check
# means something only where two such characters draw alike and a letter does not.
GLYPHS = """() => {
  const canvas = document.createElement("canvas");
  canvas.width = canvas.height = 80;
  const ctx = canvas.getContext("2d", { willReadFrequently: true });
  const draw = (ch) => {
    ctx.clearRect(0, 0, 80, 80);
    ctx.fillText(ch, 10, 55);
    return ctx.getImageData(0, 0, 80, 80).data.filter((_, i) => i % 4 === 3).join();
  };
  const fonts = new Map();
  const walk = document.createTreeWalker(document.body, NodeFilter.SHOW_TEXT);
  while (walk.nextNode()) {
    const el = walk.currentNode.parentElement;
    if (!el || !el.getClientRects().length) continue;
    const s = getComputedStyle(el);
    const font = `${s.fontStyle} ${s.fontWeight} 40px ${s.fontFamily}`;
    if (!fonts.has(font)) fonts.set(font, new Set());
    for (const ch of walk.currentNode.data) if (ch.trim()) fonts.get(font).add(ch);
  }
  const found = { drawn: [], missing: [], unsure: [] };
  for (const [font, chars] of fonts) {
    ctx.font = font;
    const box = draw("\u0378");
    if (draw("\u0379") !== box || draw("A") === box) found.unsure.push(font);
    for (const ch of chars) {
      found.drawn.push(ch);
      if (draw(ch) === box) found.missing.push(ch + " U+" + ch.codePointAt(0).toString(16));
    }
  }
  return found;
}"""
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


def check_glyphs(page: Page, shown: str) -> None:
    """Every visible character, ``shown`` among them, is drawn by a font that has it."""
    found = page.evaluate(GLYPHS)
    assert found["unsure"] == []
    assert {ch for ch in shown if not ch.isspace()} <= set(found["drawn"])
    assert found["missing"] == [], f"no installed font draws these: {FONTS}"


def check_fits(page: Page, language: str, view: str, shown: str) -> None:
    check_glyphs(page, shown + PHONE_TEXTS[language])
    assert page.evaluate("document.documentElement.scrollWidth - window.innerWidth") <= 0
    assert page.evaluate(CLIPPED) == []
    RESULTS.mkdir(exist_ok=True)
    shot = RESULTS / f"phone-{language}-{view}.png"
    page.screenshot(path=str(shot), full_page=True)
    assert shot.stat().st_size > 10_000


@pytest.mark.parametrize("language", ["ar", "ja"])
def test_right_to_left_and_cjk_text_fit_the_phone(
    server: LiveServer,
    engine: Engine,
    browser: Browser,
    extra_catalogues: MakeCatalogues,
    language: str,
) -> None:
    extra_catalogues({code: filler(text) for code, text in PHONE_TEXTS.items()})
    add_staff(engine, "pia", "pi")
    http = httpx.Client(
        base_url=server.url, timeout=60, limits=httpx.Limits(max_keepalive_connections=0)
    )
    pi = StaffApi(http).login("pia", PASSWORD)
    document = localize(default_document(), language)
    document["languages"] = ["en", language]
    # A rehearsal: there are no prompts in ar or ja, so a real session would be refused
    # (backend/wizard/readiness.py); the phone is the same for both.
    study_id = study_with_plan(pi, yaml=study_yaml(document))
    wizard = WizardBot.create(pi, study_id, rehearsal=True, language=language)
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
        check_fits(page, language, "consent", sentence)
        page.locator("#consent-agree").click()
        expect(page.locator("form#questionnaire")).to_be_visible()
        check_fits(page, language, "questionnaire", "")
        page.locator("form#questionnaire button[type=submit]").click()
        expect(page.locator("#app")).to_have_attribute("data-view", "welcome")
        wizard.start(prepare=False)
        wizard.advance(1, "discussion")
        wizard.advance(1, "ranking")
        expect(page.locator("#ranking-list .name").first).to_have_text(item)
        check_fits(page, language, "ranking", item)
    finally:
        context.close()
        http.close()


def test_the_glyph_check_sees_the_boxes_of_a_missing_font(
    playwright_instance: Playwright, browser: Browser, tmp_path: Path
) -> None:
    """With only a Latin font to draw with (fontconfig pointed at it), the same check finds
    every Arabic and Japanese character missing; with the machine's fonts, none."""
    latin = Path("/usr/share/fonts/truetype/noto/NotoSans-Regular.ttf")
    assert latin.is_file(), f"Arabic and Japanese test strings need fonts: {FONTS}"
    fonts = tmp_path / "fonts"
    fonts.mkdir()
    (fonts / latin.name).symlink_to(latin)
    config = tmp_path / "fonts.conf"
    config.write_text(
        f"<?xml version='1.0'?><fontconfig><dir>{fonts}</dir>"
        f"<cachedir>{tmp_path / 'cache'}</cachedir></fontconfig>",
        encoding="utf-8",
    )
    latin_only = playwright_instance.chromium.launch(
        executable_path=chromium_path(),
        headless=True,
        args=CHROMIUM_ARGS,
        env={**os.environ, "FONTCONFIG_FILE": str(config)},
    )
    text = "Consent " + " ".join(TEXTS["ar"] + TEXTS["ja"])
    letters = {ch for ch in text if not ch.isspace()}
    foreign = {ch for ch in letters if ord(ch) > 0x2FF}
    try:
        for shown, expected in ((latin_only, foreign), (browser, set())):
            page = shown.new_page()
            page.set_content("<body style='font-family: system-ui, sans-serif'><p></p></body>")
            page.locator("p").evaluate("(p, text) => { p.textContent = text; }", text)
            found = page.evaluate(GLYPHS)
            assert found["unsure"] == []
            assert set(found["drawn"]) == letters
            assert {m.split(" ")[0] for m in found["missing"]} == expected
            page.close()
    finally:
        latin_only.close()
