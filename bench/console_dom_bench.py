"""What the wizard sees, in a real browser: a phone's ranking -> the ranking on the wizard's
console page (the DOM of ``#participant-view``, which ``static/wizard/panels.js`` renders
from the console's state), beside the console-state message the same submission sends to
a socket of the bench's own (``bench.server_bench``'s figure), measured at the same moment.

A spot check of ``bench.server_bench``: one console page in Chromium on ``chameleons
serve`` (a fresh SQLite file), one session after another, each at its first ranking. The
difference between the two figures is what the page adds: the message's parsing and the
console's rendering.

    python -m bench.console_dom_bench [--submissions 10] [--quick] [--json FILE]
"""

from __future__ import annotations

import argparse
import json
import sys
import tempfile
import time
from functools import partial
from pathlib import Path
from typing import Any

from bench.server_burst import at_the_ranking, submit_ranking
from bench.server_load import Figures, Server, percentile
from bench.server_walk import RealServer

# The moment (ms since the epoch, as time.time() counts) the console's page first shows a
# ranking: the participant view's list of the ranked items.
OBSERVE = """() => {
  window.__rankingShown = undefined;
  const view = document.getElementById("participant-view");
  const seen = () => view.querySelector("li[data-item]") !== null;
  if (seen()) { window.__rankingShown = -1; return; }
  new MutationObserver((_records, observer) => {
    if (seen()) { window.__rankingShown = Date.now(); observer.disconnect(); }
  }).observe(view, { childList: true, subtree: true });
}"""


def run(submissions: int) -> dict[str, Any]:
    from playwright.sync_api import sync_playwright

    # ``wait_for_js`` polls ``evaluate``: the app's CSP refuses ``wait_for_function``'s eval.
    from tests.support.browser import CHROMIUM_ARGS, chromium_path, wait_for_js

    figures, shown = Figures(), []
    with (
        tempfile.TemporaryDirectory(prefix="chameleons-dom-") as tmp,
        Server.chameleons(f"sqlite:///{Path(tmp) / 'dom.sqlite3'}", sessions=submissions)
        as (server, setup),
        sync_playwright() as playwright,
    ):  # fmt: skip
        real = RealServer.of(server, setup)
        browser = playwright.chromium.launch(
            executable_path=chromium_path(), headless=True, args=CHROMIUM_ARGS
        )
        context = browser.new_context()
        context.add_cookies([{"name": name, "value": value, "url": server.base}
                             for name, value in setup["cookies"].items()])  # fmt: skip
        page = context.new_page()
        for _ in range(submissions):
            [phone], [ranking] = at_the_ranking(real, 1)
            page.goto(f"{server.base}/wizard/sessions/{phone.wizard.session_id}")
            wait_for_js(page, "document.getElementById('bar-step')?.textContent === 'ranking'")
            page.evaluate(OBSERVE)
            started = time.time()
            submit_ranking(phone, figures, ranking)
            wait_for_js(page, "window.__rankingShown !== undefined")
            at = page.evaluate("window.__rankingShown")
            if at < 0:
                raise RuntimeError("the console showed a ranking before it was submitted")
            shown.append(at / 1000 - started)
            real.release(phone, figures)
        browser.close()
    found = figures.summary()
    ms = partial(_ms, shown)
    return {"submissions": submissions, "state_p50_ms": found["state_p50_ms"],
            "state_p99_ms": found["state_p99_ms"], "dom_p50_ms": ms(0.5),
            "dom_p99_ms": ms(0.99), "errors": found["errors"]}  # fmt: skip


def _ms(values: list[float], q: float) -> float:
    return round(percentile(values, q) * 1000, 2)


def report(result: dict[str, Any]) -> None:
    print(f"A phone's ranking -> the wizard's console, {result['submissions']} submissions "
          "(SQLite, one console page in Chromium):")  # fmt: skip
    print(f"{'':34}{'p50 ms':>10}{'p99 ms':>10}")
    for label, key in (("console state message (socket)", "state"),
                       ("the ranking on the page (DOM)", "dom")):  # fmt: skip
        print(f"{label:34}{result[f'{key}_p50_ms']:>10.1f}{result[f'{key}_p99_ms']:>10.1f}")
    added = result["dom_p50_ms"] - result["state_p50_ms"]
    print(f"the page's parsing and rendering add about {added:.1f} ms at the median")
    if result["errors"]:
        print(f"errors: {result['errors']}")


def parser() -> argparse.ArgumentParser:
    found = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    found.add_argument("--submissions", type=int, default=10)
    found.add_argument("--quick", action="store_true", help="3 submissions")
    found.add_argument("--json", type=Path, help="write the figures to this file")
    return found


def main(argv: list[str] | None = None) -> int:
    arguments = parser()
    args = arguments.parse_args(argv)
    if args.submissions < 1:
        arguments.error("--submissions must be at least 1")
    result = run(3 if args.quick else args.submissions)
    report(result)
    if args.json:
        args.json.write_text(json.dumps(result, indent=2))
    return 1 if result["errors"] else 0


if __name__ == "__main__":
    sys.exit(main())
