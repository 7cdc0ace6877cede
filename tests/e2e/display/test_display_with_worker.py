"""The whole virtual-robot chain in a real Chromium: bridge commands -> a real worker (virtual
driver, 125 Hz renderer) -> ZeroMQ -> the server's display channel -> the page; and the
page's speech start/end back through the bridge to the worker, which then drives the lips.

The app does not start a bridge itself yet, so the test runs one (on its own event loop
thread) and wires it exactly as ``chameleons/backend/bridge/__init__.py`` documents."""

from __future__ import annotations

import asyncio
import queue
import threading
import time
from collections.abc import Coroutine, Iterator
from pathlib import Path
from typing import Any, TypeVar

import numpy as np
import pytest
from fastapi import FastAPI
from playwright.sync_api import Page

from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.media import media_path
from chameleons.backend.display.relay import forward_speech_events, relay_envelope
from chameleons.backend.display.tokens import signing_key
from chameleons.settings import Settings
from chameleons.worker.envelope import Message as Envelope
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.e2e.display.conftest import ACTOR, BOOTH
from tests.support.browser import wait_for_js
from tests.support.live_server import LiveServer

bridge_module = pytest.importorskip("chameleons.backend.bridge")
pytestmark = pytest.mark.browser
T = TypeVar("T")


class BridgeThread:
    """A real :class:`Bridge` on an event loop of its own."""

    def __init__(self) -> None:
        self.loop = asyncio.new_event_loop()
        self._thread = threading.Thread(target=self.loop.run_forever, daemon=True)
        self._thread.start()
        self.bridge = self.run(self._start())

    async def _start(self) -> Any:
        bridge = bridge_module.Bridge("tcp://127.0.0.1:*", "tcp://127.0.0.1:*")
        await bridge.start()
        return bridge

    def run(self, coroutine: Coroutine[Any, Any, T], timeout: float = 10.0) -> T:
        return asyncio.run_coroutine_threadsafe(coroutine, self.loop).result(timeout)

    async def send_from_other_loop(self, booth: str, kind: str, body: dict[str, Any]) -> Any:
        future = asyncio.run_coroutine_threadsafe(
            self.bridge.send_command(booth, kind, body), self.loop
        )
        return await asyncio.wrap_future(future)

    def close(self) -> None:
        self.run(self.bridge.stop())
        self.loop.call_soon_threadsafe(self.loop.stop)
        self._thread.join(timeout=10)
        self.loop.close()


def wait_until(condition: Any, timeout: float = 10.0, what: str = "") -> None:
    """Poll ``condition()`` until true (short waits on an event that never fires)."""
    deadline = time.monotonic() + timeout
    idle = threading.Event()
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"timed out waiting for {what or condition}")
        idle.wait(0.02)


@pytest.fixture
def chain(
    app: FastAPI, channel: DisplayChannel, settings: Settings, tmp_path: Path
) -> Iterator[tuple[BridgeThread, queue.Queue[Envelope]]]:
    bridge = BridgeThread()
    worker_events: queue.Queue[Envelope] = queue.Queue()
    bridge.bridge.add_listener("display.", lambda m: relay_envelope(channel, m))
    bridge.bridge.add_listener("event.", worker_events.put)
    forward_speech_events(channel, bridge.send_from_other_loop)
    config = WorkerConfig(
        booth=BOOTH, driver="virtual", data_dir=tmp_path / "worker",
        command_endpoint=bridge.bridge.command_endpoint,
        telemetry_endpoint=bridge.bridge.telemetry_endpoint,
        livelink_port=None, facecapturex_port=None,
    )  # fmt: skip
    worker = Worker(config).start()
    try:
        wait_until(lambda: BOOTH in bridge.bridge.workers(), what="the worker's hello")
        yield bridge, worker_events
    finally:
        worker.stop()
        bridge.close()


def command(bridge: BridgeThread, kind: str, body: dict[str, Any]) -> None:
    ack = bridge.run(bridge.bridge.send_command(BOOTH, kind, body, timeout=5.0))
    assert ack.ok, ack


def worker_event(events: queue.Queue[Envelope], kind: str) -> Envelope:
    while True:
        event = events.get(timeout=10)
        if event.type == kind:
            return event


def natural_clip(path: Path, yaw: float) -> Path:
    """A two-second recording holding the head turned by ``yaw`` degrees."""
    with path.open("wb") as handle:
        np.savez(handle, times=np.array([0.0, 2.0]),
                 blendshapes=np.zeros((2, N_BLENDSHAPES), dtype=np.float32),
                 head=np.array([[yaw, 0.0, 0.0]] * 2, dtype=np.float32))  # fmt: skip
    return path


def test_the_worker_drives_face_choice_and_head_pose(
    chain: tuple[BridgeThread, queue.Queue[Envelope]], display_page: Page, tmp_path: Path
) -> None:
    bridge, _events = chain
    command(bridge, "set_face", {"face_id": "face-4"})
    wait_for_js(display_page, "window.robotDisplay.state().face === 'face-4'")
    clip = natural_clip(tmp_path / "turned.npz", 30.0)
    command(bridge, "set_behaviour", {"name": "natural", "params": {"path": str(clip)}})
    wait_for_js(
        display_page,
        "(() => { const g = window.robotDisplay.geometry(); "
        "return g && g.noseX - g.centerX > 0.4 * g.scale; })()",
    )


def test_a_prompt_speaks_with_lips_moved_by_the_worker(
    chain: tuple[BridgeThread, queue.Queue[Envelope]],
    display_page: Page,
    app: FastAPI,
    live_server: LiveServer,
    settings: Settings,
) -> None:
    bridge, events = chain
    assert settings.prompts_dir is not None
    url = live_server.url + media_path(signing_key(app), ACTOR, "audio/short.wav")
    lipsync = settings.prompts_dir / ACTOR / "lipsync" / "short.csv"
    command(bridge, "play_prompt", {"prompt_id": "short", "audio_url": url,
                                    "lipsync_path": str(lipsync)})  # fmt: skip
    # The page reported the real start; the worker then opens the mouth on that clock.
    start = worker_event(events, "speech_start")
    assert start.body["prompt_id"] == "short"
    jaw = BLENDSHAPE_INDEX["jawOpen"]
    wait_for_js(display_page, f"window.robotDisplay.state().bs[{jaw}] > 0.5")
    end = worker_event(events, "speech_end")
    assert end.body["prompt_id"] == "short"
    assert 0.3 < end.body["worker_time"] - start.body["worker_time"] < 5.0


def test_the_worker_switches_the_page_to_the_3d_head_and_turns_it(
    chain: tuple[BridgeThread, queue.Queue[Envelope]], display_page: Page, tmp_path: Path
) -> None:
    """A study condition's renderer travels with set_face through the worker to the page."""
    bridge, _events = chain
    assert display_page.evaluate("window.robotDisplay.renderer().kind") == "2d"
    command(bridge, "set_face", {"face_id": "face-2", "renderer": "3d"})
    wait_for_js(display_page, "window.robotDisplay.renderer().kind === '3d'", timeout=90_000)
    clip = natural_clip(tmp_path / "turned.npz", -30.0)
    command(bridge, "set_behaviour", {"name": "natural", "params": {"path": str(clip)}})
    wait_for_js(
        display_page,
        "(() => { const g = window.robotDisplay.geometry(); "
        "return g && g.renderer === '3d' && g.centerX - g.noseX > 0.4 * g.scale; })()",
    )
