"""The console with a real bridge and a real worker (null driver): a click is acknowledged,
the robot's speech start comes back, and both latencies show on the timeline; the health
strip shows the worker's heartbeat."""

from __future__ import annotations

import re
import time
from collections.abc import AsyncIterator, Iterator
from contextlib import asynccontextmanager
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from playwright.sync_api import expect

from chameleons.backend.booth.flows import BoothFlow
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser
Bridge = pytest.importorskip("chameleons.backend.bridge").Bridge
ANY_PORT = "tcp://127.0.0.1:*"


@pytest.fixture
def app(app: FastAPI) -> FastAPI:
    """The app with a bridge started in its own lifespan (on the server's event loop), the
    way the embedded setup runs it."""
    original = app.router.lifespan_context

    @asynccontextmanager
    async def with_bridge(application: FastAPI) -> AsyncIterator[Any]:
        bridge = Bridge(ANY_PORT, ANY_PORT)
        await bridge.start()
        application.state.bridge = bridge
        # The booth flow, as bridge/wiring.py starts it: it sets the robot up as an
        # interaction starts (the console does not).
        flow = BoothFlow(application.state).start(bridge)
        try:
            async with original(application) as state:
                yield state
        finally:
            await flow.stop()
            await bridge.stop()

    app.router.lifespan_context = with_bridge
    return app


@pytest.fixture
def worker(console: Console, app: FastAPI, tmp_path: Path) -> Iterator[Worker]:
    bridge = app.state.bridge
    config = WorkerConfig(booth=console.wizard.snapshot["booth"], driver="null",
                          livelink_port=None, facecapturex_port=None, data_dir=tmp_path,
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    with Worker(config) as running:
        deadline = time.monotonic() + 10
        while config.booth not in bridge.workers():  # polls the hello; not a fixed wait
            assert time.monotonic() < deadline, "the worker did not say hello"
            time.sleep(0.02)
        yield running


@pytest.mark.usefixtures("worker")
def test_a_click_shows_its_ack_and_speech_latency(console: Console) -> None:
    page = console.page
    expect(page.locator("#health .chip[data-check='worker']")).to_have_attribute(
        "data-state", "ok", timeout=15_000
    )
    page.keyboard.press("y")
    played = page.locator("#timeline li[data-kind='prompt.played']")
    expect(played).to_have_count(1)
    expect(played.locator(".tl-latency")).to_have_text(
        re.compile(r"^ack \d+(\.\d)? ms · speech \d+(\.\d)? ms$")
    )
    expect(page.locator("#timeline li[data-kind='prompt.acked']")).to_have_count(1)
    expect(page.locator("#timeline li[data-kind='prompt.speech_start']")).to_have_count(1)
    expect(page.locator("#timeline li[data-kind='prompt.speech_end']")).to_have_count(1)
    expect(page.locator("#timeline li[data-kind='prompt.not_sent']")).to_have_count(0)
    expect(page.locator("#now-playing")).to_have_attribute("data-phase", "finished")
    kinds = [e["kind"] for e in console.events() if str(e["kind"]).startswith("prompt.")]
    assert kinds == ["prompt.played", "prompt.acked", "prompt.speech_start", "prompt.speech_end"]


@pytest.mark.usefixtures("worker")
def test_starting_an_interaction_sets_the_robot_up(console: Console) -> None:
    page = console.page
    console.wizard.switch_condition("copy", 1)  # "natural" would need a recording to replay
    primary = page.locator("#primary-action")
    expect(primary).to_contain_text("Start the session")
    page.keyboard.press("Control+Enter")
    expect(primary).to_contain_text("Start interaction 1")
    page.keyboard.press("Control+Enter")
    expect(page.locator("#timeline li[data-kind='robot.applied']")).to_have_count(1)
    expect(page.locator("#timeline li[data-kind='robot.applied']")).to_contain_text(
        "Robot set to copy"
    )
    chip = page.locator("#health .chip[data-check='behaviour']")
    expect(chip).to_have_attribute("data-state", "ok", timeout=15_000)
    expect(chip).to_contain_text("copy")


@pytest.mark.usefixtures("worker")
def test_a_failing_check_is_amber_then_red_after_the_grace_period(console: Console) -> None:
    """No face reaches the worker: the face stream check degrades, then alarms."""
    page = console.page
    chip = page.locator("#health .chip[data-check='input']")
    expect(chip).to_have_attribute("data-state", "degraded", timeout=15_000)
    expect(chip).to_contain_text("degraded")
    expect(page.locator("#health .alarm")).to_have_count(0)
    expect(chip).to_have_attribute("data-state", "bad", timeout=15_000)
    expect(page.locator("#health .alarm")).to_contain_text("Face stream")


@pytest.mark.usefixtures("worker")
def test_a_typed_sentence_is_spoken_tracked_and_logged_as_a_deviation(console: Console) -> None:
    page = console.page
    expect(page.locator("#health .chip[data-check='worker']")).to_have_attribute(
        "data-state", "ok", timeout=15_000
    )
    page.locator("#bar-participant").click()
    page.keyboard.press("Shift+T")
    expect(page.locator("#say-text")).to_be_focused()
    page.keyboard.type("The road is about seventy miles away.")
    page.keyboard.press("Enter")
    played = page.locator("#timeline li[data-kind='prompt.played']")
    expect(played).to_contain_text("▶ (typed) The road is about seventy miles away.")
    expect(played.locator(".tl-latency")).to_have_text(
        re.compile(r"^ack \d+(\.\d)? ms · speech \d+(\.\d)? ms$")
    )
    expect(page.locator("#timeline li[data-kind='wizard.typed_speech']")).to_contain_text(
        'TYPED SPEECH (deviation): "The road is about seventy miles away."'
    )
    expect(page.locator("#say-text")).to_have_value("")
    kinds = [e["kind"] for e in console.events()
             if str(e["kind"]).startswith(("prompt.", "wizard.typed"))]  # fmt: skip
    assert kinds == ["prompt.played", "wizard.typed_speech", "prompt.acked",
                     "prompt.speech_start", "prompt.speech_end"]  # fmt: skip
