"""The booth check guides the technician, in Chromium and on the command line: while the
server runs the robot in copy and measures, the page shows "Face the robot and hold still",
"Turn your head left", then "Nod", then "Hold still" (not one silent wait), and the head
step shows the measured turn and nod, from the pose held still, against the expected sign
and size. A real worker (null driver) is fed the resting pose and then the head turn and
nod over Live Link UDP when the check asks for them."""

from __future__ import annotations

import threading
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest
from click.testing import CliRunner
from fastapi import FastAPI
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.settings import Settings
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.backend.test_auth import add_user
from tests.support.bots import WizardBot, staff_api, study_with_plan
from tests.support.live_server import LiveServer
from tests.worker.head_stream import Pose, stream_after

pytestmark = pytest.mark.browser
BOOTH = "booth-5"
ANY_PORT = "tcp://127.0.0.1:*"
EXPECTED_YAW = "(expected +20..+90: turn left)"
EXPECTED_PITCH = "(expected +8..+60)"
TURN_AND_NOD = Pose(turn_at=0.3, turn_deg=40.0, turn_s=1.5, nod_at=2.0, nod_deg=15.0,
                    nod_s=1.0)  # fmt: skip


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """The server runs its worker link; the head movement is shorter than a technician's
    (the replayed turn and nod take 3 s)."""
    return settings.model_copy(update={
        "bridge_enabled": True, "worker_command_endpoint": ANY_PORT,
        "worker_telemetry_endpoint": ANY_PORT, "booth_check_turn_seconds": 2.5,
        "booth_check_nod_seconds": 2.0,
    })  # fmt: skip


@pytest.fixture
def worker(live_server: LiveServer, app: FastAPI, tmp_path: Path) -> Iterator[Worker]:
    bridge = app.state.bridge
    config = WorkerConfig(booth=BOOTH, driver="null", livelink_port=0, facecapturex_port=None,
                          capture_host="127.0.0.1", data_dir=tmp_path / "worker",
                          command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    with Worker(config) as running:
        deadline = time.monotonic() + 30
        while bridge.latest_telemetry(BOOTH)[0] is None:  # the first heartbeat, not a sleep
            assert time.monotonic() < deadline, "no heartbeat from the worker"
            time.sleep(0.05)
        yield running


def turn_and_nod(worker: Worker) -> threading.Thread:
    """The technician, as the phone streams it, in the background: still until the check
    has taken the resting pose, then the head turn and nod."""
    stats = worker.receivers["livelink"].stats
    thread = threading.Thread(target=stream_after, args=(
        worker.receivers["livelink"].port, TURN_AND_NOD, 3.5,
        lambda: stats.rest_marked_at is not None))  # fmt: skip
    thread.start()
    return thread


def test_the_page_prompts_turn_then_nod_and_shows_yaw_and_pitch_against_the_expected(
    live_server: LiveServer, page: Page, engine: Engine, worker: Worker
) -> None:
    with httpx.Client(base_url=live_server.url, timeout=30) as http:
        pi = staff_api(http, engine, "pi")
        wizard = WizardBot.create(pi, study_with_plan(pi, participants=2), booth=BOOTH)
    add_user(engine, "tech", "correct horse battery", "wizard")
    target = f"/booths/{BOOTH}/check?session_id={wizard.session_id}"
    page.goto(f"{live_server.url}/login?next={target}")
    page.get_by_label("Username").fill("tech")
    page.get_by_label("Password").fill("correct horse battery")
    page.get_by_role("button", name="Log in").click()
    root = page.locator("#booth-check")
    expect(root).to_contain_text("Expected, measured from the pose you held still: yaw "
                                 "+20..+90° (a turn to the left) and pitch +8..+60°")  # fmt: skip
    expect(root).to_contain_text("The robot copies you 4.0 s later (the study's condition copy: "
                                 "it copies everything, 4 s late")  # fmt: skip

    moving = turn_and_nod(worker)
    page.get_by_role("button", name="Run the check").click()
    prompt = page.locator("#check-prompt")
    expect(prompt).to_have_text("Face the robot and hold still")
    expect(prompt).to_have_attribute("data-phase", "rest")
    expect(prompt).to_have_text("Turn your head left (and back)")
    expect(prompt).to_have_attribute("data-phase", "turn")
    expect(prompt).to_have_text("Nod (chin down and up)")
    expect(prompt).to_have_attribute("data-phase", "nod")
    expect(prompt).to_have_text("Hold still: the robot copies you 4 s later")
    moving.join()
    summary = page.locator("#check-summary")
    expect(summary).to_contain_text("NOT READY", timeout=60_000)  # no phone stream now
    expect(prompt).to_be_hidden()
    head = page.locator("tr[data-step='head']")
    expect(head).to_have_attribute("data-status", "pass")
    expect(head).to_contain_text(EXPECTED_YAW)
    expect(head).to_contain_text(EXPECTED_PITCH)
    expect(head).to_contain_text("turn +4")  # the 40 degree turn, measured
    expect(head).to_contain_text("from a resting pose of yaw +0°, pitch +0°")
    expect(page.locator("tr[data-step='copy']")).to_contain_text(
        "delay 4.00 s configured (copy: copies everything, 4 s late"
    )


def test_the_command_prints_the_prompts_in_time_and_the_expected_ranges(
    live_server: LiveServer, app: FastAPI, engine: Engine, worker: Worker
) -> None:
    from chameleons.cli.booth_check_command import booth_check

    add_user(engine, "tech", "correct horse battery", "wizard")
    bridge = app.state.bridge

    moving = turn_and_nod(worker)  # turns the head once the check took the resting pose
    result = CliRunner().invoke(
        booth_check, ["booth-5", "--server", live_server.url, "--user", "tech"],
        input="correct horse battery\n",
    )  # fmt: skip
    moving.join()
    lines = result.output.splitlines()
    prompts = [line for line in lines if line.startswith(">>> ")]
    assert prompts[:4] == [
        ">>> Face the robot and hold still (2 s)",
        ">>> Turn your head left (and back) (2.5 s)",
        ">>> Nod (chin down and up) (2 s)",
        ">>> Hold still: the robot copies you 4 s later (6.5 s)",
    ], result.output
    assert "Expected: yaw +20..+90° (a turn to the left)" in result.output
    head = next(line for line in lines if "Turn your head left, then nod:" in line)
    assert head.startswith("PASS"), result.output
    assert EXPECTED_YAW in head
    assert EXPECTED_PITCH in head
    assert (bridge.state(BOOTH).behaviour or {}).get("name") == "still"  # restored
