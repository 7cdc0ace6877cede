"""In Chromium, the console under pressure (issue 28), without a worker: the keys come back
after Enter in a text field, a refusal's toast leaves the health strip readable, an ended
session's "End session early" is no longer red, the Say field's hint fits, and the health
strip says whether typed speech can speak."""

from __future__ import annotations

import re
import shutil

import pytest
from playwright.sync_api import Locator, Page, expect

from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser
DANGER_RED = "rgb(180, 35, 24)"  # --danger in app.css


def kinds(console: Console, kind: str) -> list[dict[str, object]]:
    return [e for e in console.events() if e["kind"] == kind]


def start_discussion(page: Page) -> None:
    primary = page.locator("#primary-action")
    expect(primary).to_contain_text("Start the session")
    primary.click()
    expect(primary).to_contain_text("Start interaction 1")
    page.keyboard.press("Control+Enter")
    expect(page.locator("#bar-step")).to_have_text("discussion")


NEEDS_ESPEAK = pytest.mark.skipif(
    shutil.which("espeak-ng") is None, reason="espeak-ng is not installed"
)


@NEEDS_ESPEAK  # the typed sentence is synthesised (no worker: logged, not sent)
def test_enter_in_the_note_or_say_field_gives_the_keys_back_to_the_console(
    console: Console,
) -> None:
    """The lab's case: a sentence said with Shift+T and Enter, then Shift+N and a note: the
    note must land on the timeline, not be spoken, and the keys play prompts again."""
    page = console.page
    start_discussion(page)
    page.keyboard.press("Shift+T")
    say = page.locator("#say-text")
    expect(say).to_be_focused()
    page.keyboard.type("The road is seventy miles away.")
    page.keyboard.press("Enter")
    expect(say).not_to_be_focused()
    expect(page.locator("#timeline li[data-kind='wizard.typed_speech']")).to_have_count(1)

    page.keyboard.press("Shift+N")
    note = page.locator("#note-text")
    expect(note).to_be_focused()
    page.keyboard.type("participant frowned")
    page.keyboard.press("Enter")
    expect(page.locator("#timeline li[data-kind='wizard.note']")).to_contain_text(
        "Note: participant frowned"
    )
    expect(note).not_to_be_focused()
    expect(note).to_have_value("")
    expect(say).to_have_value("")

    page.keyboard.press("y")  # a prompt key works at once, and types into no field
    expect(page.locator("#timeline li[data-kind='prompt.played']")).to_have_count(2)
    expect(note).to_have_value("")
    expect(say).to_have_value("")
    assert [e["payload"]["text"] for e in kinds(console, "wizard.typed_speech")] == [  # type: ignore[index]
        "The road is seventy miles away."
    ]
    played = [e["payload"]["group"] for e in kinds(console, "prompt.played")]  # type: ignore[index]
    assert played == ["typed", "ack_yes"]


def boxes_overlap(a: Locator, b: Locator) -> bool:
    first, second = a.bounding_box(), b.bounding_box()
    assert first is not None
    assert second is not None
    return not (
        first["x"] + first["width"] <= second["x"]
        or second["x"] + second["width"] <= first["x"]
        or first["y"] + first["height"] <= second["y"]
        or second["y"] + second["height"] <= first["y"]
    )


@pytest.mark.parametrize("size", [(1280, 720), (390, 844)], ids=["laptop", "phone"])
def test_a_refusal_covers_neither_the_health_strip_nor_the_primary_action(
    console: Console, size: tuple[int, int]
) -> None:
    page = console.page
    page.set_viewport_size({"width": size[0], "height": size[1]})
    expect(page.locator("#health .chip").first).to_be_visible()
    page.locator("#bar-participant").click()
    page.keyboard.press("a")  # nothing to accept yet: the console refuses in a toast
    flash = page.locator("#flash")
    expect(flash).to_contain_text("Cannot accept now.")
    assert not boxes_overlap(flash, page.locator("#health"))
    assert not boxes_overlap(flash, page.locator("#primary-action"))
    box = flash.bounding_box()
    assert box is not None
    assert 0 <= box["x"] <= box["x"] + box["width"] <= size[0]


def test_an_ended_sessions_end_button_is_off_and_not_red(console: Console) -> None:
    page = console.page
    end = page.locator("#end-open")
    expect(end).to_be_enabled()
    assert end.evaluate("b => getComputedStyle(b).backgroundColor") == DANGER_RED
    console.wizard.end("time", "")
    expect(end).to_be_disabled()
    expect(page.locator("#primary-action")).to_contain_text("Session ended early")
    background = end.evaluate("b => getComputedStyle(b).backgroundColor")
    color = end.evaluate("b => getComputedStyle(b).color")
    assert DANGER_RED not in (background, color), (background, color)


def test_the_say_fields_hint_fits_at_1280(console: Console) -> None:
    page = console.page
    page.set_viewport_size({"width": 1280, "height": 720})
    say = page.locator("#say-text")
    expect(say).to_be_visible()
    # The placeholder's width in the field's own font against the room the field gives it.
    needed, room = say.evaluate(
        """(input) => {
          const style = getComputedStyle(input);
          const context = document.createElement("canvas").getContext("2d");
          context.font = `${style.fontWeight} ${style.fontSize} ${style.fontFamily}`;
          const padding = parseFloat(style.paddingLeft) + parseFloat(style.paddingRight);
          const room = input.clientWidth - padding;
          return [context.measureText(input.placeholder).width, room];
        }"""
    )
    assert needed <= room, f"the hint needs {needed:.0f} px, the field has {room:.0f}"
    expect(say).to_have_attribute("placeholder", re.compile(r"\(Shift\+T\)$"))


@NEEDS_ESPEAK
def test_the_health_strip_says_typed_speech_can_speak(console: Console) -> None:
    """The server looked for espeak-ng at its start-up (this machine has it)."""
    chip = console.page.locator("#health .chip[data-check='typed_speech']")
    expect(chip).to_contain_text(re.compile(r"^Typed speech espeak-ng \d"))
    expect(chip).to_have_attribute("data-state", "ok")


def test_the_questions_before_the_interactions_read_so_on_the_timeline(
    console: Console,
) -> None:
    """The console's fixture answered the questions before the session (position -1)."""
    row = console.page.locator("#timeline li[data-kind='questionnaire.submitted']")
    expect(row).to_have_count(1)
    expect(row).to_contain_text("answered (before the interactions)")
    expect(row).not_to_contain_text("-1")
    consent = console.page.locator("#timeline li[data-kind='consent.given']")
    expect(consent).to_contain_text("Phone: consent given")


def test_marking_the_participant_a_rehearsal_reaches_the_open_console(
    console: Console,
) -> None:
    page, wizard = console.page, console.wizard
    tag = page.locator("#bar-rehearsal")
    expect(page.locator("#primary-action")).to_be_enabled()
    expect(tag).to_be_hidden()
    code = page.locator("#bar-participant").inner_text()
    rehearsal = f"/api/pi/participants/{code}/rehearsal"
    wizard.staff.post(rehearsal, {"rehearsal": True})
    expect(tag).to_be_visible()  # live: no reload
    expect(page.locator("#timeline li[data-kind='session.rehearsal_marked']")).to_have_text(
        re.compile("Marked as a rehearsal")
    )
    wizard.staff.post(rehearsal, {"rehearsal": False})
    expect(tag).to_be_hidden()
    expect(page.locator("#timeline li[data-kind='session.rehearsal_unmarked']")).to_have_count(1)
