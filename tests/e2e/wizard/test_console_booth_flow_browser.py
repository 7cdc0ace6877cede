"""In Chromium, the console with the server's own worker link (bridge, booth flow, display
relay, as ``bridge/wiring.py`` starts them in a lab) and a real worker: the robot is set
up once per interaction start, the timeline reads in wall-clock time, the Speaking chip
follows the speech events as they arrive, and Escape stops the robot from a text field."""

from __future__ import annotations

import json
import re
import time
from collections.abc import Iterator
from pathlib import Path

import pytest
from fastapi import FastAPI
from playwright.sync_api import BrowserContext, Page, WebSocketRoute, expect

from chameleons.backend.display.tokens import display_path, signing_key
from chameleons.settings import Settings
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.e2e.wizard.conftest import Console
from tests.support.browser import wait_for_js

pytestmark = pytest.mark.browser
ANY_PORT = "tcp://127.0.0.1:*"
SET_UP = ("robot.applied", "robot.not_applied")


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """The server starts its worker link (and booth flow) itself, on free loopback ports."""
    return settings.model_copy(update={
        "bridge_enabled": True, "worker_command_endpoint": ANY_PORT,
        "worker_telemetry_endpoint": ANY_PORT,
    })  # fmt: skip


def running_worker(console: Console, app: FastAPI, folder: Path, driver: str) -> Worker:
    """A real worker of the console's booth on the server's own bridge, once it said hello."""
    bridge = app.state.bridge
    config = WorkerConfig(booth=console.wizard.snapshot["booth"], driver=driver,
                          livelink_port=None, facecapturex_port=None, data_dir=folder,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    worker = Worker(config).start()
    deadline = time.monotonic() + 30
    while config.booth not in bridge.workers():  # polls the hello; not a fixed wait
        if time.monotonic() > deadline:
            worker.stop()
            raise AssertionError("the worker did not say hello")
        time.sleep(0.02)
    return worker


@pytest.fixture
def worker(console: Console, app: FastAPI, tmp_path: Path) -> Iterator[Worker]:
    """The null driver: a robot that speaks each prompt for its length, silently."""
    running = running_worker(console, app, tmp_path / "null", "null")
    yield running
    running.stop()


def start_interaction(page: Page) -> None:
    expect(page.locator("#health .chip[data-check='worker']")).to_have_attribute(
        "data-state", "ok"
    )
    primary = page.locator("#primary-action")
    expect(primary).to_contain_text("Start the session")
    page.keyboard.press("Control+Enter")
    expect(primary).to_contain_text("Start interaction 1")
    page.keyboard.press("Control+Enter")
    expect(page.locator("#bar-step")).to_have_text("discussion")


@pytest.mark.usefixtures("worker")
def test_starting_an_interaction_logs_one_robot_set_up(console: Console) -> None:
    """The server's booth flow sets the robot up as the interaction starts; the console used
    to do it again, and the timeline read "Robot set to ..." twice."""
    page = console.page
    console.wizard.switch_condition("copy", 1)  # "natural" would need a recording to replay
    start_interaction(page)
    applied = page.locator("#timeline li[data-kind='robot.applied']")
    expect(applied).to_have_count(1)
    expect(applied).to_contain_text("Robot set to copy")
    chip = page.locator("#health .chip[data-check='behaviour']")
    expect(chip).to_have_attribute("data-state", "ok")
    expect(chip).to_contain_text("copy")
    page.keyboard.press("y")  # something after it, so a late second set-up had its time
    expect(page.locator("#timeline li[data-kind='prompt.speech_end']")).to_have_count(1)
    set_ups = [(e["kind"], e["source"]) for e in console.events() if e["kind"] in SET_UP]
    assert set_ups == [("robot.applied", "server")]


@pytest.mark.usefixtures("worker")
def test_the_timeline_shows_wall_clock_times_not_the_workers_clock(console: Console) -> None:
    page = console.page
    start_interaction(page)
    page.keyboard.press("y")
    start = page.locator("#timeline li[data-kind='prompt.speech_start']")
    expect(start).to_have_count(1)
    expect(start.locator("time")).to_have_text(re.compile(r"^\d\d:\d\d:\d\d\.\d{3}$"))
    expect(start).not_to_contain_text(re.compile(r"worker \d"))  # no raw worker clock
    expect(start.locator(".tl-source")).to_have_text("worker")
    # The worker's clock is kept for an audit: in the export and the time's tooltip.
    stored = next(e for e in console.events() if e["kind"] == "prompt.speech_start")
    assert isinstance(stored["worker_time"], float)
    expect(start.locator("time")).to_have_attribute(
        "title", f"worker clock {stored['worker_time']:.3f} s"
    )


SPEAKING_HISTORY = """() => {
  window.speakingSeen = [];
  const strip = document.getElementById("health");
  const note = () => {
    const chip = strip.querySelector(".chip[data-check='speaking']");
    const value = chip && chip.textContent.trim().split(" ").pop();  // "Speaking quiet"
    if (value && window.speakingSeen[window.speakingSeen.length - 1] !== value) {
      window.speakingSeen.push(value);
    }
  };
  new MutationObserver(note).observe(strip, { childList: true, subtree: true });
  note();
}"""


@pytest.mark.usefixtures("worker")
def test_the_speaking_chip_follows_the_speech_events(console: Console) -> None:
    """The heartbeat's speaking flag is frozen at its first quiet sample (as a lagging one
    would be: every later heartbeat repeats it, ever older): only the speech start and end
    events can move the chip. They did not: it waited for the heartbeat."""
    page = console.page
    frozen: dict[str, float] = {}

    def relay(socket: WebSocketRoute) -> None:
        server = socket.connect_to_server()

        def to_page(message: str | bytes) -> None:
            data = json.loads(message) if isinstance(message, str) else {}
            if data.get("type") == "health":
                checks = {c["id"]: c for c in data["checks"]}
                if not frozen and checks["worker"]["ok"] and checks["speaking"]["value"] == "quiet":
                    frozen.update(at=time.monotonic(), age=data.get("speaking_age_s", 0.0))
                if frozen:
                    checks["speaking"].update(ok=True, level="ok", value="quiet")
                    data["speaking_age_s"] = frozen["age"] + time.monotonic() - frozen["at"]
                    frozen["sent"] = frozen.get("sent", 0) + 1
                message = json.dumps(data)
            socket.send(message)

        server.on_message(to_page)
        socket.on_message(server.send)

    page.route_web_socket("**/ws/wizard/sessions/*", relay)
    page.reload()
    chip = page.locator("#health .chip[data-check='speaking']")
    expect(chip).to_contain_text("quiet")
    start_interaction(page)
    page.evaluate(SPEAKING_HISTORY)
    page.keyboard.press("i")  # the introduction: a few seconds of (null-driver) speech
    expect(page.locator("#timeline li[data-kind='prompt.speech_end']")).to_have_count(1)
    expect(chip).to_contain_text("quiet")
    assert page.evaluate("window.speakingSeen") == ["quiet", "speaking", "quiet"]
    assert frozen["sent"] > 2, "heartbeats came, frozen"


@pytest.mark.usefixtures("worker")
def test_escape_in_a_text_field_stops_the_robot(console: Console) -> None:
    page = console.page
    start_interaction(page)
    page.keyboard.press("e")  # the scenario: long enough to be speaking for a while
    expect(page.locator("#timeline li[data-kind='prompt.speech_start']")).to_have_count(1)
    page.keyboard.press("Shift+N")
    note = page.locator("#note-text")
    expect(note).to_be_focused()
    page.keyboard.type("about to stop")
    page.keyboard.press("Escape")
    expect(note).not_to_be_focused()
    expect(page.locator("#timeline li[data-kind='prompt.stopped']")).to_contain_text(
        "Stopped the prompt"
    )
    expect(page.locator("#timeline li[data-kind='prompt.speech_end']")).to_contain_text(
        "stopped"
    )
    expect(note).to_have_value("about to stop")  # kept: nothing typed is lost
    # Nothing speaking: Escape only leaves the field, no stop goes on the timeline.
    page.keyboard.press("Shift+N")
    page.keyboard.press("Escape")
    expect(note).not_to_be_focused()
    assert len([e for e in console.events() if e["kind"] == "prompt.stopped"]) == 1


def test_a_robot_set_up_the_server_could_not_send_is_flashed(console: Console) -> None:
    """No worker on the link: the booth flow logs the set-up as failed and the console says
    so where the wizard looks."""
    page = console.page
    expect(page.locator("#health .chip[data-check='worker']")).to_have_attribute(
        "data-state", "bad"
    )
    page.keyboard.press("Control+Enter")
    expect(page.locator("#primary-action")).to_contain_text("Start interaction 1")
    page.keyboard.press("Control+Enter")
    failed = page.locator("#timeline li[data-kind='robot.not_applied']")
    expect(failed).to_have_count(1)
    expect(page.locator("#flash")).to_contain_text("Robot not set to")
    set_ups = [(e["kind"], e["source"]) for e in console.events() if e["kind"] in SET_UP]
    assert set_ups == [("robot.not_applied", "server")]


@pytest.fixture
def virtual_worker(console: Console, app: FastAPI, tmp_path: Path) -> Iterator[Worker]:
    """The built-in virtual robot: its face and voice are the booth's display page."""
    running = running_worker(console, app, tmp_path / "virtual", "virtual")
    yield running
    running.stop()


@pytest.mark.usefixtures("virtual_worker")
def test_a_prompt_cut_short_by_the_display_closing_is_not_voiced(
    console: Console, app: FastAPI, screen_context: BrowserContext
) -> None:
    """No robot display open: the play is not voiced, its button says so. Then the display
    page closes while it speaks: the play ends "not voiced" with the reason, its button
    has no tick, and the Speaking chip goes quiet."""
    page = console.page
    start_interaction(page)
    page.keyboard.press("y")  # nobody hears it: no display page is open
    yes = page.locator("#prompt-sections button.pb[data-group='ack_yes']")
    expect(yes.locator(".pb-played")).to_have_text("✗ not voiced")
    expect(yes.locator(".pb-played")).to_have_attribute(
        "title", re.compile(r"^Not voiced: no robot display open")
    )

    display = screen_context.new_page()  # its own window: tests/support/browser.py
    booth = console.wizard.snapshot["booth"]
    display.goto(console.server.url + display_path(signing_key(app), booth))
    wait_for_js(display, "window.robotDisplay && window.robotDisplay.connected()")
    robot = page.locator("#health .chip[data-check='robot']")
    expect(robot).to_have_attribute("data-state", "ok")
    page.keyboard.press("i")  # heard to its end: a tick
    intro = page.locator("#timeline li[data-kind='prompt.speech_end']")
    expect(intro).to_have_count(1)
    button = page.locator("#prompt-sections button.pb[data-stage='intro']")
    expect(button.locator(".pb-played")).to_have_text("✓")

    page.keyboard.press("e")  # the scenario: several seconds long
    expect(page.locator("#timeline li[data-kind='prompt.speech_start']")).to_have_count(2)
    chip = page.locator("#health .chip[data-check='speaking']")
    expect(chip).to_contain_text("speaking")
    display.close()
    ended = page.locator("#timeline li[data-kind='prompt.speech_end']").first
    expect(ended).to_contain_text("NOT PLAYED: the robot display was closed while it played")
    scenario = page.locator("#prompt-sections button.pb.not-voiced[data-stage='scenario']")
    expect(scenario).to_have_count(1)
    expect(scenario.locator(".pb-played")).to_have_text("✗ not voiced")
    expect(page.locator("#now-playing")).to_have_attribute("data-phase", "not-sent")
    expect(chip).to_contain_text("quiet")
    end = next(e for e in reversed(console.events()) if e["kind"] == "prompt.speech_end")
    assert end["payload"]["reason"] == "display_closed"  # type: ignore[index]
