"""The robots of ``bench.speech_bench`` and what tells the bench when each starts speaking.

- **virtual**: the booth's real display page (``/display/...``) in headless Chromium
  (Playwright, the launch flags of ``tests/support/browser.py``). An init script notes the
  page's clock (``performance.timeOrigin + performance.now()``) whenever the page reports
  a speech start to the server: the moment its audio element fired ``playing``. The page's
  clock is mapped onto the bench's by the quickest of a few ``evaluate`` round trips just
  before each play (the mapping's uncertainty is half that round trip, reported).
- **furhat**: the project's Furhat Realtime API peer (``tests/worker/furhat_peer.py``,
  no start latency of its own) in this process: the moment it sends
  ``response.speak.start`` is on the bench's own clock.

Each robot is driven by a real ``chameleons worker`` process connected to the server's
worker link, as in a lab.
"""

from __future__ import annotations

import os
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from playwright.sync_api import Page, sync_playwright
from websockets.asyncio.server import ServerConnection

from bench.server_load import ROOT
from chameleons.backend.display.tokens import display_path
from tests.support.browser import CHROMIUM_ARGS, chromium_path
from tests.worker.furhat_peer import FurhatPeer

WAIT_S = 30.0
SPEECH_START_SCRIPT = """(() => {
  window.__benchStarts = [];
  const send = WebSocket.prototype.send;
  WebSocket.prototype.send = function (data) {
    if (typeof data === "string" && data.indexOf('"speech"') >= 0) {
      try {
        const m = JSON.parse(data);
        if (m.type === "speech" && m.event === "start") {
          window.__benchStarts.push({prompt: m.prompt_id,
                                     t: performance.timeOrigin + performance.now()});
        }
      } catch (err) { /* not the bench's business */ }
    }
    return send.call(this, data);
  };
})();"""
PAGE_CLOCK = "performance.timeOrigin + performance.now()"


class Robot:
    """Tells the bench when the robot started speaking the play after :meth:`before_play`."""

    name = "robot"
    worker_args: list[str] = []

    def before_play(self) -> None:
        raise NotImplementedError

    def speech_start(self, prompt_id: str) -> float | None:
        """The speech start (bench clock, ``time.perf_counter``), or None if none came."""
        raise NotImplementedError

    def clock_uncertainty_ms(self) -> float:
        return 0.0


class DisplayPage(Robot):
    name = "virtual"
    worker_args = ["--driver", "virtual"]

    def __init__(self, page: Page) -> None:
        self.page = page
        self._seen = 0
        self._offset_ms = 0.0  # page clock - bench clock
        self._uncertainty_ms = 0.0

    def before_play(self) -> None:
        self._seen = int(self.page.evaluate("window.__benchStarts.length"))
        samples = []
        for _ in range(10):
            before = time.perf_counter() * 1000
            page_ms = float(self.page.evaluate(PAGE_CLOCK))
            after = time.perf_counter() * 1000
            samples.append((after - before, page_ms - (before + after) / 2))
        trip, self._offset_ms = min(samples)
        self._uncertainty_ms = trip / 2

    def speech_start(self, prompt_id: str) -> float | None:
        deadline = time.monotonic() + WAIT_S
        while time.monotonic() < deadline:
            starts = self.page.evaluate(f"window.__benchStarts.slice({self._seen})")
            for start in starts:
                if start["prompt"] == prompt_id:
                    return (float(start["t"]) - self._offset_ms) / 1000
            self.page.wait_for_timeout(5)  # lets Playwright run the page's events
        return None

    def clock_uncertainty_ms(self) -> float:
        return self._uncertainty_ms


class TimedFurhatPeer(FurhatPeer):
    """The Furhat test peer, noting on the bench's clock when it says it started."""

    def __init__(self, **options: Any) -> None:
        super().__init__(**options)
        self.starts: list[float] = []
        self._started = threading.Condition()

    async def reply(self, ws: ServerConnection, kind: str, request: dict[str, Any],
                    **fields: Any) -> None:  # fmt: skip
        if kind == "response.speak.start":
            with self._started:
                self.starts.append(time.perf_counter())
                self._started.notify_all()
        await super().reply(ws, kind, request, **fields)

    def start_after(self, seen: int) -> float | None:
        with self._started:
            self._started.wait_for(lambda: len(self.starts) > seen, WAIT_S)
            return self.starts[seen] if len(self.starts) > seen else None


class Furhat(Robot):
    name = "furhat"

    def __init__(self, peer: TimedFurhatPeer) -> None:
        self.peer = peer
        self.worker_args = ["--driver", "furhat", "--robot-url", peer.url]
        self._seen = 0

    def before_play(self) -> None:
        self._seen = len(self.peer.starts)

    def speech_start(self, prompt_id: str) -> float | None:
        return self.peer.start_after(self._seen)


@contextmanager
def display_page(base_url: str, secret_key: str, booth: str) -> Iterator[DisplayPage]:
    """The booth's display page in headless Chromium, connected to the server."""
    with sync_playwright() as playwright:
        browser = playwright.chromium.launch(executable_path=chromium_path(), headless=True,
                                             args=CHROMIUM_ARGS)  # fmt: skip
        try:
            page = browser.new_page()
            page.add_init_script(SPEECH_START_SCRIPT)
            page.goto(base_url + display_path(secret_key.encode(), booth))
            deadline = time.monotonic() + WAIT_S
            while not page.evaluate("window.robotDisplay && window.robotDisplay.connected()"):
                if time.monotonic() > deadline:
                    raise RuntimeError("the robot display page did not connect")
                page.wait_for_timeout(20)
            yield DisplayPage(page)
        finally:
            browser.close()


@contextmanager
def furhat() -> Iterator[Furhat]:
    peer = TimedFurhatPeer(start_latency=0.0, speech_seconds=0.3)
    with peer:
        yield Furhat(peer)


@contextmanager
def worker(booth: str, robot: Robot, endpoints: tuple[str, str], data_dir: Path) -> Iterator[None]:
    """``chameleons worker`` for ``booth`` on the server's worker link; stopped with Ctrl-C
    (SIGINT), as a technician stops it."""
    command = [sys.executable, "-m", "chameleons", "worker", "--booth", booth,
               *robot.worker_args, "--control", endpoints[0], "--telemetry", endpoints[1],
               "--livelink-port", "0", "--facecapturex-port", "0"]  # fmt: skip
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(data_dir / booth)}
    process = subprocess.Popen(command, cwd=ROOT, env=env, stdin=subprocess.DEVNULL)
    try:
        yield
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(30)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
