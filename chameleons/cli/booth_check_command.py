"""``chameleons booth-check BOOTH``: the booth check from a terminal (the same check as the
page ``/booths/<booth>/check``, run and stored by the server). While the server runs the
robot in copy and measures, the prompts it plans (hold still, turn the head left, nod, hold
still) are printed in time."""

from __future__ import annotations

import concurrent.futures
from typing import Any

import click
import httpx

TIMEOUT_S = 120  # the head movement, the robot's copy after the study's delay, the prompt


@click.command("booth-check")
@click.argument("booth")
@click.option("--server", default="http://127.0.0.1:8000", show_default=True,
              help="The chameleons server.")  # fmt: skip
@click.option("--user", "username", required=True, help="A staff account (wizard or PI).")
@click.option("--password", prompt=True, hide_input=True, envvar="CHAMELEONS_CHECK_PASSWORD",
              help="Asked for when not given (or CHAMELEONS_CHECK_PASSWORD).")  # fmt: skip
@click.option("--session", "session_id", type=int, default=None,
              help="Store the result with this session (its booth must be BOOTH).")  # fmt: skip
@click.option("--condition", default=None,
              help="Check this copy condition of the study, with its parameters (default: "
              "the session's next copy condition, else the study's first).")  # fmt: skip
@click.option(
    "--no-wait",
    is_flag=True,
    help="Skip the head movement and the robot's copy (that step then fails).",
)
def booth_check(
    booth: str, server: str, username: str, password: str, session_id: int | None,
    condition: str | None, no_wait: bool,
) -> None:  # fmt: skip
    """Check a booth before a participant: face stream, head turn and nod, robot, copy
    delay, test prompt and disk space. Exits 1 when a step fails."""
    from urllib.parse import urlencode

    from chameleons.backend.sessions.bot import ApiError, StaffApi

    chosen = {"session_id": session_id, "condition": condition}
    given = {k: v for k, v in chosen.items() if v is not None}
    query = f"?{urlencode(given)}" if given else ""
    try:
        with httpx.Client(base_url=server, timeout=TIMEOUT_S) as http:
            staff = StaffApi(http).login(username, password)
            path = f"/api/booths/{booth}/check{query}"
            if no_wait:
                result = staff.post(path + ("&" if query else "?") + "movement=false")
            else:
                result = _guided(staff, path)
    except (httpx.HTTPError, ApiError) as exc:
        raise click.ClickException(f"the check could not run: {exc}") from exc
    for step in result["steps"]:
        click.echo(f"{step['status'].upper():5} {step['label']}: {step['value']}")
    if result.get("checked_on"):  # which robot: a booth may have the display and a Furhat
        click.echo(f"{result['checked_on']}.")
    click.echo("Booth ready." if result["passed"] else "NOT READY: fix the failing steps.")
    raise SystemExit(0 if result["passed"] else 1)


def _guided(staff: Any, path: str) -> dict[str, Any]:
    """Run the check and print each prompt of the server's plan for its time."""
    plan = staff.get(path)
    click.echo(f"Expected: {plan['expected_head']}.")
    if plan.get("copy_condition"):
        click.echo(f"Condition {plan['copy_condition']}: the robot {plan['behaviour_words']}.")
    with concurrent.futures.ThreadPoolExecutor(max_workers=1) as pool:
        answer = pool.submit(staff.post, path)
        for step in plan["prompts"]:
            click.echo(f">>> {step['text']} ({step['seconds']:g} s)")
            try:
                return dict(answer.result(timeout=float(step["seconds"])))
            except concurrent.futures.TimeoutError:
                continue
        click.echo(">>> Listen: the robot says a test prompt...")
        return dict(answer.result(timeout=TIMEOUT_S))
