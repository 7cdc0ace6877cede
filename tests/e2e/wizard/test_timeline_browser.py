"""In Chromium, the console's timeline: newest first, in sentences that never show an
absolute path (the worker's recording paths are the server's business), and an event
committed late (an id below rows already shown) sorted into its place, not put on top."""

from __future__ import annotations

from pathlib import PurePosixPath
from typing import Any

import pytest
from playwright.sync_api import expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.events import repository as events
from tests.e2e.wizard.conftest import Console

pytestmark = pytest.mark.browser
DATA = "/srv/chameleons-lab/data/recordings/study-1/P001"


def _worker_events(engine: Engine, console: Console) -> None:
    """What a booth's worker reports about recordings (absolute paths on the booth PC), and
    a kind the console has no sentence for, with paths in its payload."""
    snapshot = console.wizard.refresh()
    log = {"source": "worker", "study_id": snapshot["study_id"],
           "session_id": console.wizard.session_id}  # fmt: skip
    with session_scope(build_sessionmaker(engine)) as db:
        events.record(db, "recording.started", **log, payload={
            "position": 1, "files": {"participant": f"{DATA}/i1-participant.parquet",
                                     "robot": f"{DATA}/i1-robot.parquet"}})  # fmt: skip
        events.record(db, "recording.stopped", **log, payload={
            "position": 1, "recordings": [f"{DATA}/i1-participant.parquet",
                                          f"{DATA}/i1-robot.parquet"]})  # fmt: skip
        events.record(db, "worker.disk_checked", **log, payload={
            "directory": DATA, "free_gb": 42, "details": {"mount": "/srv"}})  # fmt: skip


def test_the_timeline_is_newest_first_and_shows_no_absolute_paths(
    console: Console, engine: Engine
) -> None:
    wizard, page = console.wizard, console.page
    wizard.start()
    wizard.advance(1, "discussion")
    _worker_events(engine, console)
    page.reload()  # the events written straight to the database: read them with the page
    rows = page.locator("#timeline li")
    expect(rows.first).to_have_attribute("data-kind", "worker.disk_checked")
    ids = [int(i) for i in rows.evaluate_all("(all) => all.map((li) => li.dataset.id)")]
    stored = [int(str(e["id"])) for e in console.events()]
    assert ids == sorted(stored, reverse=True)  # every event, newest first
    times = rows.locator("time").evaluate_all("(all) => all.map((t) => t.dateTime)")
    assert times == sorted(times, reverse=True)
    texts = rows.locator(".tl-text").all_inner_texts()
    assert not [t for t in texts if "/srv" in t or DATA in t], texts
    started = page.locator("#timeline li[data-kind='recording.started'] .tl-text")
    expect(started).to_have_text("Recording interaction 1 (participant and robot)")
    expect(page.locator("#timeline li[data-kind='worker.disk_checked'] .tl-text")).to_have_text(
        f"worker.disk_checked (directory {PurePosixPath(DATA).name}, free_gb 42)"
    )
    # A new event goes on top, live.
    wizard.advance(1, "ranking")
    expect(rows.first).to_have_attribute("data-kind", "interaction.advanced")
    expect(rows.first).to_contain_text("discussion → ranking")


def test_an_event_committed_late_is_sorted_into_place(console: Console) -> None:
    """The console's own Timeline (the module the page runs) given a live update whose new
    event has an id below rows already shown, as a transaction that committed late gives."""
    page = console.page
    expect(page.locator("#timeline li").first).to_be_visible()
    order: list[Any] = page.evaluate(
        """async () => {
          const { Timeline } = await import("/static/wizard/timeline.js");
          const list = document.createElement("ol");
          const timeline = new Timeline(list, document.createElement("span"));
          const at = (id) => new Date(Date.UTC(2026, 0, 1, 10, 0, id)).toISOString();
          const note = (id) => ({ id, kind: "wizard.note", source: "wizard",
                                  server_time: at(id), payload: { text: `note ${id}` } });
          timeline.sync([note(1), note(2), note(4)], new Map());
          timeline.sync([note(1), note(2), note(3), note(4)], new Map());  // 3 came late
          timeline.sync([note(1), note(2), note(3), note(4), note(5)], new Map());
          return [...list.children].map((li) => Number(li.dataset.id));
        }"""
    )
    assert order == [5, 4, 3, 2, 1]
