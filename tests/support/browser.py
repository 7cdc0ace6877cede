"""Playwright fixtures driving a real Chromium (Debian's /usr/bin/chromium when present)."""

from __future__ import annotations

import os
import shutil
import time
from collections.abc import Iterator, Sized
from pathlib import Path

import pytest
from playwright.sync_api import (
    Browser,
    BrowserContext,
    Page,
    Playwright,
    expect,
    sync_playwright,
)

CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--autoplay-policy=no-user-gesture-required",
]


# Upper bounds, not waits (every expect polls until its condition holds): on a loaded
# 2-core laptop (load 7-12) a page or a live server answers in seconds, and Playwright's own
# 5 s for an expect failed tests that passed alone.
EXPECT_TIMEOUT_MS = 20_000
ACTION_TIMEOUT_MS = 30_000


def chromium_path() -> str | None:
    """CHAMELEONS_CHROMIUM, else Debian's chromium, else None (Playwright's own browser)."""
    configured = os.environ.get("CHAMELEONS_CHROMIUM")
    if configured:
        return configured
    for candidate in ("/usr/bin/chromium", shutil.which("chromium") or ""):
        if candidate and Path(candidate).exists():
            return candidate
    return None


@pytest.fixture(scope="session")
def playwright_instance() -> Iterator[Playwright]:
    expect.set_options(timeout=EXPECT_TIMEOUT_MS)
    with sync_playwright() as pw:
        yield pw


@pytest.fixture(scope="session")
def browser(playwright_instance: Playwright) -> Iterator[Browser]:
    browser = playwright_instance.chromium.launch(
        executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS
    )
    yield browser
    browser.close()


@pytest.fixture
def context(browser: Browser) -> Iterator[BrowserContext]:
    ctx = browser.new_context()
    yield ctx
    ctx.close()


@pytest.fixture
def screen_context(browser: Browser) -> Iterator[BrowserContext]:
    """A window of its own for the booth's robot display, as on the booth's own screen. A
    display opened with ``context.new_page()`` beside a page the test then clicks in (the
    booth check, the console) is a background tab: Chromium then runs its
    ``requestAnimationFrame`` about once a second (measured: 1-2 frames a second against 60;
    its ``visibilityState`` still says "visible"), so the display reports 0 or 1 frames a
    second and the robot's presence depends on the second it is asked."""
    ctx = browser.new_context()
    yield ctx
    ctx.close()


@pytest.fixture
def page(context: BrowserContext) -> Page:
    page = context.new_page()
    page.set_default_timeout(ACTION_TIMEOUT_MS)
    return page


@pytest.fixture
def phone_context(browser: Browser) -> Iterator[BrowserContext]:
    """A small phone: 375 px wide, touch, mobile user agent."""
    ctx = browser.new_context(
        viewport={"width": 375, "height": 740},
        has_touch=True,
        is_mobile=True,
        device_scale_factor=2,
    )
    yield ctx
    ctx.close()


def wait_for_js(page: Page, expression: str, timeout: float = 30_000) -> None:
    """Wait until ``expression`` is truthy in the page.

    Playwright's ``wait_for_function`` compiles its predicate with ``eval`` inside the
    page, which the app's Content-Security-Policy (no 'unsafe-eval') refuses; ``evaluate``
    goes through the DevTools protocol, which the policy does not govern. So this polls
    ``evaluate`` until the condition holds (a readiness poll with a deadline, not a fixed
    wait), letting Playwright dispatch the page's events in between.
    """
    deadline = time.monotonic() + timeout / 1000
    while not page.evaluate(expression):
        if time.monotonic() > deadline:
            raise TimeoutError(f"{expression!r} still false after {timeout / 1000:.0f} s")
        page.wait_for_timeout(20)


def wait_until_routed(page: Page, taken: Sized, timeout: float = 60_000) -> None:
    """Wait until a route handler has put a request into ``taken``: handlers run only while
    Playwright is being called, so this polls through Playwright with a deadline."""
    deadline = time.monotonic() + timeout / 1000
    while not taken:
        if time.monotonic() > deadline:
            raise TimeoutError(f"no request routed after {timeout / 1000:.0f} s")
        page.wait_for_timeout(20)
