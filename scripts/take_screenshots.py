"""Take the documentation's screenshots from a real demo session, so they stay current.

Starts `chameleons demo` itself (free ports, a temporary data dir, so it never disturbs a
demo already running), runs one whole three-interaction session in three browser contexts
(wizard console, participant phone, robot display) the way a newcomer would, rehearses a
few more participants so the analysis has something to show, and writes palette-optimised
PNGs to docs/screenshots/.

    .venv/bin/python scripts/take_screenshots.py [--out docs/screenshots] [--keep DIR]

Chromium: CHAMELEONS_CHROMIUM, else /usr/bin/chromium, else Playwright's own browser.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass
from pathlib import Path

import httpx
from PIL import Image
from playwright.sync_api import (
    Browser,
    BrowserContext,
    Locator,
    Page,
    ViewportSize,
    expect,
    sync_playwright,
)

ROOT = Path(__file__).resolve().parent.parent
CHROMIUM_ARGS = [
    "--no-sandbox",
    "--disable-gpu",
    "--disable-quic",
    "--no-first-run",
    "--disable-background-networking",
    "--disable-component-update",
    "--disable-sync",
    "--autoplay-policy=no-user-gesture-required",
    # Software WebGL for the display's 3D head (no GPU needed).
    "--use-angle=swiftshader",
    "--enable-unsafe-swiftshader",
]
WIZARD_VIEWPORT = ViewportSize(width=1280, height=960)
DISPLAY_VIEWPORT = ViewportSize(width=640, height=480)
PI_VIEWPORT = ViewportSize(width=1200, height=900)
REHEARSED = 11  # with the session driven here, one balance period (12) of the plan
TIMEOUT_MS = 20_000


@dataclass(frozen=True)
class Demo:
    base: str
    wizard_url: str
    display_url: str
    phone_url: str
    credentials: dict[str, str]


def free_port(kind: int = socket.SOCK_STREAM) -> int:
    with socket.socket(socket.AF_INET, kind) as sock:
        sock.bind(("127.0.0.1", 0))
        port: int = sock.getsockname()[1]
        return port


@contextmanager
def running_demo(data_dir: Path) -> Iterator[Demo]:
    """`chameleons demo` on free ports; stopped with Ctrl-C (SIGINT) as a person would."""
    port = free_port()
    env = {
        **os.environ,
        "PYTHONUNBUFFERED": "1",
        "CHAMELEONS_DATA_DIR": str(data_dir),
        "CHAMELEONS_WORKER_COMMAND_ENDPOINT": f"tcp://127.0.0.1:{free_port()}",
        "CHAMELEONS_WORKER_TELEMETRY_ENDPOINT": f"tcp://127.0.0.1:{free_port()}",
        "CHAMELEONS_LIVELINK_PORT": str(free_port(socket.SOCK_DGRAM)),
        "CHAMELEONS_FACECAPTUREX_PORT": str(free_port()),
    }
    log = (data_dir / "demo.log").open("w")
    command = [sys.executable, "-m", "chameleons", "demo", "--port", str(port)]
    process = subprocess.Popen(command, env=env, stdout=log, stderr=subprocess.STDOUT, cwd=ROOT)
    try:
        base = f"http://127.0.0.1:{port}"
        wait_healthy(base, process, data_dir / "demo.log")
        yield read_welcome(base, data_dir)
    finally:
        process.send_signal(signal.SIGINT)
        try:
            process.wait(20)
        except subprocess.TimeoutExpired:
            process.kill()
            process.wait()
        log.close()


def wait_healthy(base: str, process: subprocess.Popen[bytes], log: Path) -> None:
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline:
        if process.poll() is not None:
            raise SystemExit(f"chameleons demo exited early:\n{log.read_text()}")
        try:
            if httpx.get(f"{base}/healthz", timeout=2).status_code == 200:
                return
        except httpx.HTTPError:
            pass
        time.sleep(0.2)
    raise SystemExit(f"chameleons demo did not become healthy:\n{log.read_text()}")


def read_welcome(base: str, data_dir: Path) -> Demo:
    """The URLs the demo printed, and the staff logins it stored."""
    text = (data_dir / "demo.log").read_text()

    def url(label: str) -> str:
        match = re.search(rf"^\s+{label}\s+(http\S+)", text, re.MULTILINE)
        if match is None:
            raise SystemExit(f"no '{label}' URL in the demo's welcome text:\n{text}")
        return match.group(1)

    credentials = json.loads((data_dir / "demo-credentials.json").read_text())
    return Demo(base, url("wizard console"), url("robot display"), url("participant"), credentials)


def log_in(page: Page, demo: Demo, username: str, target: str) -> None:
    page.goto(f"{demo.base}/login?next={target}")
    page.get_by_label("Username").fill(username)
    page.get_by_label("Password").fill(demo.credentials[username])
    page.get_by_role("button", name="Log in").click()
    page.wait_for_url(f"**{target}")


class Shots:
    """Screenshots into ``out``, each reduced to a 256-colour palette and optimised."""

    def __init__(self, out: Path) -> None:
        self.out = out
        out.mkdir(parents=True, exist_ok=True)

    def take(self, page: Page, name: str, *, height: int | None = None) -> None:
        path = self.out / f"{name}.png"
        if height is None:
            page.screenshot(path=path)
        else:
            width = page.viewport_size["width"] if page.viewport_size else 1200
            page.screenshot(path=path, full_page=True, clip={
                "x": 0, "y": 0, "width": width, "height": height})  # fmt: skip
        self._done(path)

    def take_element(self, locator: Locator, name: str) -> None:
        path = self.out / f"{name}.png"
        locator.screenshot(path=path)
        self._done(path)

    def _done(self, path: Path) -> None:
        optimise(path)
        print(f"  {path.relative_to(ROOT) if path.is_relative_to(ROOT) else path}"
              f"  {path.stat().st_size // 1024} KB")  # fmt: skip


def optimise(path: Path) -> None:
    with Image.open(path) as image:
        palette = image.convert("RGB").quantize(colors=256, method=Image.Quantize.MEDIANCUT)
    palette.save(path, optimize=True)


def compose_overview(out: Path) -> None:
    """The README's one picture: the wizard console beside the robot (the 3D head) it drives."""
    with Image.open(out / "wizard-console.png") as console, \
            Image.open(out / "robot-display-3d.png") as robot:  # fmt: skip
        console_rgb = console.convert("RGB")
        robot_rgb = robot.convert("RGB")
    scale = 720 / console_rgb.height
    size = (round(console_rgb.width * scale), 720)
    console_rgb = console_rgb.resize(size, Image.Resampling.LANCZOS)
    gap = 16
    canvas = Image.new("RGB", (console_rgb.width + gap + robot_rgb.width, 720), (238, 240, 243))
    canvas.paste(console_rgb, (0, 0))
    canvas.paste(robot_rgb, (console_rgb.width + gap, (720 - robot_rgb.height) // 2))
    path = out / "overview.png"
    canvas.save(path)
    optimise(path)
    print(f"  {path.name}  {path.stat().st_size // 1024} KB")


def phone_context(browser: Browser) -> BrowserContext:
    return browser.new_context(
        viewport={"width": 375, "height": 740}, has_touch=True, is_mobile=True,
        device_scale_factor=2,
    )  # fmt: skip


def run_session(browser: Browser, demo: Demo, shots: Shots) -> None:
    """The whole session as a newcomer runs it from the printed URLs."""
    wizard = browser.new_context(viewport=WIZARD_VIEWPORT).new_page()
    wizard.set_default_timeout(TIMEOUT_MS)
    log_in(wizard, demo, "wizard", demo.wizard_url.removeprefix(demo.base))
    display = browser.new_context(viewport=DISPLAY_VIEWPORT).new_page()
    display.goto(demo.display_url)
    display.mouse.click(10, 10)  # the booth screen's one click that allows sound
    phone = phone_context(browser).new_page()
    phone.set_default_timeout(TIMEOUT_MS)
    phone.goto(demo.phone_url)
    expect(wizard.locator("#phone-state")).to_have_text("phone connected")
    # The procedure before the session: consent, then the skippable questions about them.
    phone.get_by_role("button", name="I agree to take part").click()
    expect(phone.get_by_role("heading", name="About you")).to_be_visible()
    phone.get_by_role("button", name=re.compile(r"^Save")).click()
    expect(phone.get_by_role("heading", name="Welcome!")).to_be_visible()
    # The supervised worker connects a moment after the server; an interaction started
    # before that would leave the robot in the wrong condition.
    worker = wizard.locator("#health .chip[data-check='worker']")
    expect(worker).to_have_attribute("data-state", "ok", timeout=60_000)
    primary = wizard.locator("#primary-action")
    expect(primary).to_contain_text("Start the session")
    primary.click()
    for position in (1, 2, 3):
        if position == 2:  # the same booth's display with the 3D head (?renderer=3d)
            display.goto(demo.display_url + "?renderer=3d")
            display.mouse.click(10, 10)
            expect(display.locator("#face3d")).to_be_visible(timeout=90_000)
        run_interaction(wizard, phone, display, position, shots)
    expect(phone.get_by_role("heading", name="Final questions")).to_be_visible()
    answer_questionnaire_page(phone, last=True)
    expect(primary).to_contain_text("Session complete")


def run_interaction(wizard: Page, phone: Page, display: Page, position: int, shots: Shots) -> None:
    primary = wizard.locator("#primary-action")
    expect(primary).to_contain_text(f"Start interaction {position}")
    primary.click()
    expect(wizard.locator("#bar-step")).to_have_text("discussion")
    # As a wizard does: each prompt starts before the next is pressed (a prompt pressed
    # over one that has not started yet is skipped, and flagged "prompt not voiced").
    speak(wizard, lambda: wizard.get_by_role("button", name=re.compile(r"Introduce")).click())
    speak(wizard, lambda: wizard.get_by_role("button", name=re.compile(r"Scenario")).click())
    if position in (1, 2):
        display.wait_for_timeout(600)  # mid-sentence, mouth moving
        shots.take(display, "robot-display" if position == 1 else "robot-display-3d")
    primary.click()  # hand over: ranking on the phone
    expect(phone.get_by_role("heading", name="Rank the items")).to_be_visible()
    phone.locator("#ranking-list li").last.get_by_role("button", name=re.compile(" up$")).click()
    if position == 1:
        shots.take(phone, "phone-ranking")
    phone.get_by_role("button", name="Submit my ranking").click()
    expect(wizard.locator("#live-ranking li")).to_have_count(5)
    primary.click()  # negotiation
    negotiate(wizard, position, shots)
    primary.click()  # questionnaire
    expect(wizard.locator("#bar-step")).to_have_text("questionnaire")
    for part in (1, 2, 3, 4):
        expect(phone.locator(".progress-label")).to_have_text(f"Part {part} of 4")
        if position == 1 and part == 1:
            phone.locator("fieldset.question").first.locator("label.point").nth(5).click()
            phone.locator("fieldset.question").nth(1).locator("label.point").nth(4).click()
            shots.take(phone, "phone-questionnaire")
        answer_questionnaire_page(phone)


def negotiate(wizard: Page, position: int, shots: Shots) -> None:
    """Three suggestions: the robot voices each, the wizard records the answer."""
    panel = wizard.locator("#negotiation-body")
    for index in (1, 2, 3):
        expect(panel).to_contain_text(f"Suggestion {index} of 3")
        speak(wizard, lambda: wizard.keyboard.press("m"))  # the suggestion's first phrasing
        if position == 1 and index == 2:
            expect(wizard.locator("#now-playing")).to_contain_text("Playing")
            wizard.evaluate("window.scrollTo(0, 0)")
            shots.take(wizard, "wizard-console")
        wizard.keyboard.press("a" if (index + position) % 2 else "d")
    expect(panel.locator("li.yes, li.no")).to_have_count(3)


def speak(wizard: Page, press: Callable[[], None]) -> None:
    """Press a prompt and wait until the robot display reported its speech start."""
    started = wizard.locator("#timeline li").filter(has_text="Speech started")
    before = started.count()
    press()
    expect(started).to_have_count(before + 1)


def answer_questionnaire_page(phone: Page, *, last: bool = False) -> None:
    for question in phone.locator("fieldset.question").all():
        if question.locator("textarea").count():
            question.locator("textarea").fill("The robot seemed attentive.")
        elif question.locator("input:checked").count():
            continue
        elif question.locator("label.point").count():
            question.locator("label.point").nth(4).click()
        else:  # a choice (the manipulation check): its first answer
            question.get_by_role("radio").first.check()
    phone.get_by_role("button", name=re.compile(r"^Save")).click()
    if last:  # the session ends: the phone explains the study (the debriefing)
        expect(phone.get_by_role("heading", name="What this study was about")).to_be_visible()
    else:
        expect(phone.locator("#save-status")).to_have_text("Answers saved ✓")


def rehearse(demo: Demo, data_dir: Path) -> bool:
    """More participants (rehearsals with a built-in effect) so the analysis shows one."""
    command = [
        sys.executable, "-m", "chameleons", "rehearse", "--server", demo.base,
        "--username", "wizard", "--password", demo.credentials["wizard"],
        "--participants", str(REHEARSED), "--pattern", "effect", "--script", "silent",
    ]  # fmt: skip
    env = {**os.environ, "CHAMELEONS_DATA_DIR": str(data_dir)}
    result = subprocess.run(command, env=env, capture_output=True, text=True, timeout=300)
    if result.returncode != 0:
        print(f"rehearse failed ({result.returncode}); the analysis shows one participant:\n"
              f"{result.stdout}{result.stderr}", file=sys.stderr)  # fmt: skip
    return result.returncode == 0


def pi_page(browser: Browser, demo: Demo) -> Page:
    page = browser.new_context(viewport=PI_VIEWPORT).new_page()
    page.set_default_timeout(TIMEOUT_MS)
    log_in(page, demo, "pi", "/pi")
    return page


def dashboard(page: Page, shots: Shots) -> None:
    """The PI's view of the session just run (before any rehearsal)."""
    page.reload()
    expect(page.get_by_role("heading", name="Study progress")).to_be_visible()
    shots.take(page, "pi-dashboard", height=1250)


def analysis(page: Page, demo: Demo, shots: Shots, rehearsed: bool) -> None:
    query = "?include_rehearsal=true" if rehearsed else ""
    page.goto(f"{demo.base}/pi/analysis{query}")
    expect(page.locator("img").first).to_be_visible()
    # Not wait_for_function: its in-page eval is refused by the app's CSP (no unsafe-eval).
    loaded = "[...document.querySelectorAll('img')].every((i) => i.complete && i.naturalWidth)"
    deadline = time.monotonic() + 60
    while not page.evaluate(loaded) and time.monotonic() < deadline:
        page.wait_for_timeout(50)
    shots.take(page, "analysis", height=1100)
    shots.take_element(page.locator("section[aria-labelledby='plots-heading']"), "analysis-plots")


def monitor(page: Page, demo: Demo, shots: Shots) -> None:
    """The booths monitor after the session (the booth's worker and robot still reporting)."""
    page.goto(f"{demo.base}/pi/monitor")
    expect(page.locator(".booth .chips .chip").first).to_be_visible()
    shots.take(page, "pi-monitor", height=520)


def power(page: Page, demo: Demo, shots: Shots) -> None:
    """The power page after one simulation with its default (the paper's pilot) effects."""
    page.goto(f"{demo.base}/pi/power")
    # The simulation runs before the result page loads: wait for that page, not the click.
    page.locator("#simulate").click(no_wait_after=True)
    expect(page.locator("#power-heading")).to_be_visible(timeout=180_000)
    shots.take_element(page.locator("#power-result"), "pi-power")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "screenshots")
    parser.add_argument("--keep", type=Path, help="Keep the demo's data dir here.")
    args = parser.parse_args()
    shots = Shots(args.out.resolve())
    with tempfile.TemporaryDirectory(prefix="chameleons-shots-") as tmp:
        data_dir = Path(tmp)
        with running_demo(data_dir) as demo, sync_playwright() as pw:
            browser = pw.chromium.launch(
                executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS
            )
            run_session(browser, demo, shots)
            pi = pi_page(browser, demo)
            dashboard(pi, shots)
            monitor(pi, demo, shots)
            analysis(pi, demo, shots, rehearse(demo, data_dir))
            power(pi, demo, shots)
            browser.close()
        if args.keep:
            shutil.copytree(data_dir, args.keep, dirs_exist_ok=True)
    compose_overview(shots.out)
    total = sum(p.stat().st_size for p in shots.out.glob("*.png"))
    print(f"{total // 1024} KB in {shots.out}")


def chromium_path() -> str | None:
    configured = os.environ.get("CHAMELEONS_CHROMIUM")
    if configured:
        return configured
    found = shutil.which("chromium") or "/usr/bin/chromium"
    return found if Path(found).exists() else None


if __name__ == "__main__":
    main()
