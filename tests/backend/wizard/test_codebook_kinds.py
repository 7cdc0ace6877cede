"""The codebook's examples of event kinds and sources are ones the code really writes
(issue 28: it named ``interaction_started`` and ``prompt_played``, which no event has, and a
source ``phone``). A whole session runs through the HTTP API with a real worker (null
driver) on a real bridge; every kind and source the codebook names must be in its export."""

from __future__ import annotations

import csv
import io
import random
import re
import zipfile

import pytest
from fastapi.testclient import TestClient

from tests.backend.wizard.conftest import api
from tests.backend.wizard.test_worker_path import bridge, until, worker
from tests.support.bots import ParticipantBot, WizardBot, drive_session

__all__ = ["bridge", "worker"]  # the fixtures this module uses


def examples(description: str) -> list[str]:
    """The words a codebook description lists in its parentheses ("(e.g. a, b, c)")."""
    inside = re.search(r"\(([^)]*)\)", description)
    assert inside is not None, description
    words = [w.strip(" .") for w in inside.group(1).removeprefix("e.g.").split(",")]
    return [w for w in words if w and w != "..."]


@pytest.mark.usefixtures("worker")
def test_the_codebook_names_only_event_kinds_and_sources_the_code_writes(
    client: TestClient, wizard: WizardBot
) -> None:
    play = wizard.staff.post(f"{api(wizard)}/prompts/play", {"group": "ack_yes"})
    assert play["sent"] is True, play["detail"]
    until(lambda: any(e["kind"] == "prompt.speech_end" for e in wizard.staff.get(
        f"/api/sessions/{wizard.session_id}/events")))  # fmt: skip
    phone = ParticipantBot(client, wizard.token)
    drive_session(wizard, phone, random.Random(5))

    study = wizard.snapshot["study_id"]
    bundle = zipfile.ZipFile(io.BytesIO(client.get("/api/pi/export.zip",
                                                   params={"study": study}).content))  # fmt: skip
    events = list(csv.DictReader(io.StringIO(bundle.read("events.csv").decode())))
    book = {(r["table"], r["column"]): r["description"]
            for r in csv.DictReader(io.StringIO(bundle.read("codebook.csv").decode()))}  # fmt: skip
    kinds, sources = {e["kind"] for e in events}, {e["source"] for e in events}

    named_kinds = examples(book[("events", "kind")])
    assert len(named_kinds) >= 4, named_kinds
    assert set(named_kinds) <= kinds, sorted(set(named_kinds) - kinds)
    named_sources = examples(book[("events", "source")])
    assert len(named_sources) >= 3, named_sources
    assert set(named_sources) <= sources, sorted(set(named_sources) - sources)
