"""Recording faults are never silent (issue 15): a read-only recordings folder and a full disk,
with a real worker (threads, real ZeroMQ, a Live Link sender) and the real server (bridge,
booth flow, HTTP API). Either turns the wizard's *Recording* chip red with one sentence,
flags the interaction on the PI dashboard and in the export, and no server job crashes.

The faults are real file systems: a read-only tmpfs (or, without root, a folder without
write permission) and a 256 kB tmpfs. Mounting needs root (and a kernel that lets the
container mount tmpfs); otherwise the full-disk test is skipped with that reason.
"""

from __future__ import annotations

import contextlib
import csv
import io
import logging
import os
import subprocess
import zipfile
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI

from chameleons.backend.bridge import Bridge
from chameleons.backend.wizard import worker_link
from chameleons.backend.wizard.health import HealthTracker
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import (  # noqa: F401 - fixtures
    BOOTH,
    bridge,
    feed_face,
    finish_interaction,
    flow,
    new_session,
    pi,
    study_id,
    timeline,
    until,
    wait_for_event,
    worker,
)
from tests.support.bots import StaffApi

pytestmark = pytest.mark.usefixtures("flow")


def _mount(target: Path, options: str) -> None:
    if os.geteuid() != 0:
        pytest.skip("mounting a tmpfs needs root (run the suite as root or in CI's container)")
    target.mkdir(parents=True, exist_ok=True)
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(target)],
                          capture_output=True, text=True, check=False)  # fmt: skip
    if done.returncode != 0:
        pytest.skip(f"this machine does not let us mount a tmpfs: {done.stderr.strip()}")


@contextlib.contextmanager
def mounted(target: Path, options: str) -> Iterator[Path]:
    _mount(target, options)
    try:
        yield target
    finally:
        subprocess.run(["umount", "-l", str(target)], check=False)


@contextlib.contextmanager
def read_only(target: Path) -> Iterator[Path]:
    """A read-only folder: a read-only tmpfs as root (root writes through permissions),
    else a folder without write permission."""
    if os.geteuid() == 0:
        with mounted(target, "ro,size=64k") as path:
            yield path
        return
    target.mkdir(parents=True, exist_ok=True)
    target.chmod(0o555)
    try:
        yield target
    finally:
        target.chmod(0o755)


def failing_chip(bridge: Bridge) -> dict[str, Any] | None:  # noqa: F811 - the fixture's name
    """The *Recording* chip of the wizard's health strip, once it is failing."""
    telemetry, age = worker_link.latest_telemetry(bridge, BOOTH)
    snapshot = HealthTracker().snapshot(BOOTH, telemetry, age)
    chip = next((c for c in snapshot["checks"] if c["id"] == "recording"), None)
    return chip if chip is not None and chip["ok"] is False else None


def export_interactions(pi: StaffApi, study: int) -> list[dict[str, str]]:  # noqa: F811
    bundle = pi.http.get("/api/pi/export.zip", params={"study": study})
    assert bundle.status_code == 200, bundle.text
    with zipfile.ZipFile(io.BytesIO(bundle.content)) as archive:
        name = next(n for n in archive.namelist() if n.endswith("interactions.csv"))
        text = archive.read(name).decode("utf-8-sig")
    return list(csv.DictReader(io.StringIO(text)))


def assert_flagged(pi: StaffApi, study: int, session_id: int, words: str) -> None:  # noqa: F811
    page = pi.http.get(f"/pi/sessions/{session_id}")
    assert page.status_code == 200
    assert 'data-flag="recording"' in page.text
    assert words in page.text
    rows = [r for r in export_interactions(pi, study) if r["session"] == str(session_id)]
    problem = next(r["recording_problem"] for r in rows if r["position"] == "1")
    assert words in problem
    assert all(not r["recording_problem"] for r in rows if r["position"] != "1")


def server_errors(caplog: pytest.LogCaptureFixture) -> list[logging.LogRecord]:
    """Errors the server logged (a booth flow job that raised logs one)."""
    return [r for r in caplog.records
            if r.levelno >= logging.ERROR and r.name.startswith("chameleons.backend")]  # fmt: skip


def recordings_dir(app: FastAPI) -> Path:
    return Path(app.state.settings.data_dir) / "recordings"


def test_a_read_only_recordings_folder_turns_the_chip_red_and_is_flagged(
    app: FastAPI, pi: StaffApi, study_id: int, worker: Worker, bridge: Bridge,  # noqa: F811
    caplog: pytest.LogCaptureFixture,
) -> None:  # fmt: skip
    caplog.set_level(logging.WARNING)
    with read_only(recordings_dir(app)):
        wizard, _ = new_session(pi, study_id)
        # The booth check before the participant (refused once an interaction runs).
        checked = pi.post(f"/api/booths/{BOOTH}/check?movement=false&say=false")
        disk = next(s for s in checked["steps"] if s["id"] == "disk")
        wizard.start()
        wizard.advance(1, "discussion")
        not_started = wait_for_event(wizard, "recording.not_started")
        chip = until(lambda: failing_chip(bridge), what="a red Recording chip")
    assert disk["status"] == "fail"
    assert "is read-only" in disk["value"]
    detail = not_started["payload"]["detail"]
    assert not_started["payload"]["reason"] == "recording_failed"
    assert "is read-only: nothing is being recorded." in detail
    assert "{" not in detail  # a sentence, not raw JSON
    assert "Errno" not in detail
    assert (chip["level"], chip["label"]) == ("alarm", "Recording")
    assert "read-only" in chip["value"]
    assert_flagged(pi, study_id, wizard.session_id, "read-only")
    assert not server_errors(caplog)


def test_a_full_disk_turns_the_chip_red_is_flagged_and_crashes_no_job(
    app: FastAPI, pi: StaffApi, study_id: int, worker: Worker, bridge: Bridge,  # noqa: F811
    caplog: pytest.LogCaptureFixture,
) -> None:  # fmt: skip
    caplog.set_level(logging.WARNING)
    with mounted(recordings_dir(app), "size=256k"):
        wizard, phone = new_session(pi, study_id)
        wizard.switch_condition("copy", 1)
        wizard.start()
        wizard.advance(1, "discussion")
        wait_for_event(wizard, "recording.started")

        def fill_the_disk() -> None:
            chip = until(lambda: feed_face(worker, 1.0) and failing_chip(bridge), timeout=60,
                         what="a red Recording chip")  # fmt: skip
            assert chip["level"] == "alarm"
            assert "The disk is full where recordings are written" in chip["value"]

        finish_interaction(wizard, phone, 1, fill_the_disk)
        failed = wait_for_event(wizard, "recording.failed")
        until(lambda: any(e["kind"] in ("recording.stopped", "recording.not_stopped")
                          for e in timeline(wizard)), what="the recording's stop")  # fmt: skip
        assert_flagged(pi, study_id, wizard.session_id, "The disk is full")
    assert failed["payload"]["reason"].startswith("The disk is full where recordings are written")
    assert worker.recorder.status()["frames_lost"] > 0
    # The indexing job met the full disk too (the journals cannot become Parquet there): it
    # reported that instead of raising; the booth flow logged no failed job.
    assert not server_errors(caplog)
    failures = [e["payload"] for e in timeline(wizard) if e["kind"] == "recording.failed"]
    by_server = [p for p in failures if p["source"] == "server"]
    assert by_server
    assert by_server[0]["reason"].startswith("The disk is full")
