"""``chameleons booth-check BOOTH``: the booth check from a terminal (the same check as the
page ``/booths/<booth>/check``, run and stored by the server)."""

from __future__ import annotations

import time

import click
import httpx

HEAD_SECONDS = 12  # the turn and nod, then the robot's copy after the copy delay


@click.command("booth-check")
@click.argument("booth")
@click.option("--server", default="http://127.0.0.1:8000", show_default=True,
              help="The chameleons server.")  # fmt: skip
@click.option("--user", "username", required=True, help="A staff account (wizard or PI).")
@click.option("--password", prompt=True, hide_input=True, envvar="CHAMELEONS_CHECK_PASSWORD",
              help="Asked for when not given (or CHAMELEONS_CHECK_PASSWORD).")  # fmt: skip
@click.option("--session", "session_id", type=int, default=None,
              help="Store the result with this session (its booth must be BOOTH).")  # fmt: skip
@click.option("--no-wait", is_flag=True, help="Do not wait for the head turn and nod.")
def booth_check(
    booth: str, server: str, username: str, password: str, session_id: int | None,
    no_wait: bool,
) -> None:  # fmt: skip
    """Check a booth before a participant: face stream, head turn and nod, robot, copy
    delay and disk space. Exits 1 when a step fails."""
    from chameleons.backend.sessions.bot import ApiError, StaffApi

    try:
        with httpx.Client(base_url=server, timeout=30) as http:
            staff = StaffApi(http).login(username, password)
            if not no_wait:
                click.echo(f"Turn your head to the left and back, then nod ({HEAD_SECONDS} s)...")
                time.sleep(HEAD_SECONDS)
            query = f"?session_id={session_id}" if session_id is not None else ""
            result = staff.post(f"/api/booths/{booth}/check{query}")
    except (httpx.HTTPError, ApiError) as exc:
        raise click.ClickException(f"the check could not run: {exc}") from exc
    for step in result["steps"]:
        click.echo(f"{step['status'].upper():5} {step['label']}: {step['value']}")
    click.echo("Booth ready." if result["passed"] else "NOT READY: fix the failing steps.")
    raise SystemExit(0 if result["passed"] else 1)
