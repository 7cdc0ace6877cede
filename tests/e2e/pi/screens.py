"""The PI's pages on a desk screen and on a phone: a fresh browser context of that size,
logged in as the PI ``pia`` (each test adds the user) on the page asked for."""

from __future__ import annotations

from playwright.sync_api import Browser, BrowserContext, Page

from tests.e2e.pi.test_dashboard_browser import SLOW

SCREENS = {"desk": (1280, 720), "phone": (390, 844)}


def pi_page(browser: Browser, url: str, screen: str) -> tuple[BrowserContext, Page]:
    width, height = SCREENS[screen]
    context = browser.new_context(viewport={"width": width, "height": height})
    page = context.new_page()
    page.set_default_timeout(SLOW)
    page.goto(url)
    page.get_by_label("Username").fill("pia")
    page.get_by_label("Password").fill("correct horse")
    page.get_by_role("button", name="Log in").click()
    return context, page
