"""The booth follows the session through a real bridge to a real worker: an interaction
started only through the session API sets the robot up and is recorded; the recording is
indexed and downloadable; ``natural`` replays the study's clip, the yoked recording (the clip
until one exists) or a synthetic face, as the study says, and each interaction records it."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.bridge import Bridge
from chameleons.backend.models import Interaction, Recording
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import (
    BOOTH,
    feed_face,
    finish_interaction,
    new_session,
    participant_frames_recorded,
    timeline,
    until,
    wait_for_event,
)
from tests.experiment.study_files import with_natural
from tests.support.bots import StaffApi, WizardBot, study_with_plan

pytestmark = pytest.mark.usefixtures("flow")


def recordings_of(app: FastAPI, interaction_id: int) -> list[Recording]:
    with app.state.sessionmaker() as db:
        query = select(Recording).where(Recording.interaction_id == interaction_id)
        return list(db.scalars(query.order_by(Recording.stream, Recording.path)))


def interaction_id(app: FastAPI, wizard: WizardBot, position: int = 1) -> int:
    with app.state.sessionmaker() as db:
        query = select(Interaction.id).where(
            Interaction.session_id == wizard.session_id, Interaction.position == position
        )
        return int(db.scalars(query).one())


def record_interaction(wizard: WizardBot, phone: Any, worker: Worker) -> dict[str, Any]:
    """Interaction 1 from discussion to done with a face fed in; the recording.stopped event."""
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "recording.started")

    def face() -> None:
        feed_face(worker)
        until(lambda: participant_frames_recorded(worker) > 0, what="participant frames")

    finish_interaction(wizard, phone, 1, face)
    return wait_for_event(wizard, "recording.stopped")


def test_an_interaction_started_through_the_api_sets_up_the_robot_and_is_recorded(
    app: FastAPI, pi: StaffApi, study_id: int, worker: Worker, bridge: Bridge
) -> None:
    wizard, phone = new_session(pi, study_id)
    wizard.switch_condition("copy", 1)
    wizard.start()
    interaction = wizard.interaction(1)
    stopped = record_interaction(wizard, phone, worker)

    applied = next(e for e in timeline(wizard) if e["kind"] == "robot.applied")
    assert applied["source"] == "server"
    assert applied["interaction_id"] == interaction_id(app, wizard)
    assert (applied["payload"]["condition"], applied["payload"]["face"]) == (
        "copy", interaction["face"],
    )  # fmt: skip
    # The study's behaviour and parameters, not the condition's name alone.
    assert bridge.state(BOOTH).behaviour == {"name": "copy", "params": {"delay": 4.0}}
    assert bridge.state(BOOTH).face == {"face_id": interaction["face"]}

    rows = recordings_of(app, interaction_id(app, wizard))
    assert {r.stream for r in rows} == {"participant", "agent"}
    participant = next(r for r in rows if r.stream == "participant")
    assert participant.frames > 0
    assert participant.size_bytes > 0
    assert not Path(participant.path).is_absolute()  # relative to the data directory
    expected_dir = f"recordings/study-{study_id}/session-{wizard.session_id}/"
    assert participant.path.startswith(expected_dir)
    assert {r["id"] for r in stopped["payload"]["recordings"]} == {r.id for r in rows}

    # The PI's session detail offers the files, and they download.
    page = pi.http.get(f"/pi/sessions/{wizard.session_id}")
    assert f"/pi/recordings/{participant.id}" in page.text
    download = pi.http.get(f"/pi/recordings/{participant.id}")
    assert download.status_code == 200
    assert download.content[:4] == b"PAR1"


def natural_interaction(app: FastAPI, wizard: WizardBot) -> Interaction:
    with app.state.sessionmaker() as db:
        found: Interaction | None = db.get(Interaction, interaction_id(app, wizard))
        assert found is not None
        return found


def test_natural_replays_the_yoked_recording_of_an_earlier_participant(
    app: FastAPI, pi: StaffApi, worker: Worker, bridge: Bridge, tmp_path: Path
) -> None:
    study_id = study_with_plan(pi, 3, yaml=with_natural(source="yoked", yoked_min_seconds=0))
    first, first_phone = new_session(pi, study_id)
    first.switch_condition("still", 1)
    first.start()
    record_interaction(first, first_phone, worker)
    source = next(
        r for r in recordings_of(app, interaction_id(app, first)) if r.stream == "participant"
    )

    # Like a booth PC: the worker has its own data directory, with the shared recordings
    # volume at the same relative place.
    server_recordings = Path(app.state.settings.data_dir) / "recordings"
    (tmp_path / "worker").mkdir(exist_ok=True)
    (tmp_path / "worker" / "recordings").symlink_to(server_recordings.resolve())
    second, _ = new_session(pi, study_id)
    second.switch_condition("natural", 1)
    second.start()
    second.advance(1, "discussion")
    applied = wait_for_event(second, "robot.applied")
    chosen = applied["payload"]["natural_source"]
    assert chosen["source"] == "yoked"
    assert chosen["recording_id"] == source.id
    assert chosen["from_interaction_id"] == interaction_id(app, first)
    assert (chosen["from_participant"], chosen["from_position"], chosen["from_condition"]) == (
        first.snapshot["participant"]["code"], 1, "still",
    )  # fmt: skip
    path = f"data:{source.path}"  # the worker resolves it against its own data directory
    assert chosen["path"] == path
    assert bridge.state(BOOTH).behaviour == {
        "name": "natural", "params": {"offset": 0.0, "loop": True, "path": path},
    }  # fmt: skip
    logged = [e for e in timeline(second) if e["kind"] == "behaviour.natural_source"]
    assert [e["payload"]["recording_id"] for e in logged] == [source.id]
    recorded = natural_interaction(app, second)
    assert recorded.natural_source == "yoked"
    assert recorded.natural_recording == (
        f"participant {first.snapshot['participant']['code']}, interaction 1 (still), "
        f"recording {source.id}"
    )
    # The console shows it for the interaction.
    assert second.refresh()["interactions"][0]["natural"]["source"] == "yoked"


def test_yoked_replays_the_clip_until_another_participant_was_recorded(
    app: FastAPI, pi: StaffApi, worker: Worker, bridge: Bridge
) -> None:
    study_id = study_with_plan(pi, 3, yaml=with_natural(source="yoked", clip="demo-natural"))
    wizard, _ = new_session(pi, study_id)
    wizard.switch_condition("natural", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    applied = wait_for_event(wizard, "robot.applied")  # the worker loaded the clip
    path = "prompts:_natural/demo-natural.npz"
    assert applied["payload"]["natural_source"] == {
        "source": "clip", "clip": "demo-natural", "path": path,
        "note": "yoked: no recording of another participant yet", "synthetic_demo": True,
    }  # fmt: skip
    recorded = natural_interaction(app, wizard)
    assert recorded.natural_source == "clip"
    assert recorded.natural_recording == (
        "clip demo-natural (yoked: no recording of another participant yet; "
        "the synthetic demo clip, not a real conversation)"
    )


def test_natural_replays_the_studys_clip_by_default(
    app: FastAPI, pi: StaffApi, study_id: int, worker: Worker, bridge: Bridge
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.switch_condition("natural", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    applied = wait_for_event(wizard, "robot.applied")  # the worker loaded the clip
    path = "prompts:_natural/demo-natural.npz"  # the worker's own prompts folder
    assert applied["payload"]["natural_source"] == {
        "source": "clip", "clip": "demo-natural", "path": path, "synthetic_demo": True,
    }  # fmt: skip
    assert applied["payload"]["behaviour_name"] == "natural"
    assert bridge.state(BOOTH).behaviour == {
        "name": "natural", "params": {"offset": 0.0, "loop": True, "path": path},
    }  # fmt: skip
    assert natural_interaction(app, wizard).natural_recording == (
        "clip demo-natural (the synthetic demo clip, not a real conversation)"
    )


def test_a_synthetic_source_is_used_only_when_the_study_asks_for_it(
    app: FastAPI, pi: StaffApi, worker: Worker, bridge: Bridge
) -> None:
    study_id = study_with_plan(pi, 3, yaml=with_natural(source="synthetic", seed=5, offset=2))
    wizard, _ = new_session(pi, study_id)
    wizard.switch_condition("natural", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    applied = wait_for_event(wizard, "robot.applied")
    assert applied["payload"]["natural_source"] == {"source": "synthetic", "seed": 5}
    assert bridge.state(BOOTH).behaviour == {
        "name": "natural", "params": {"offset": 2.0, "loop": True, "seed": 5},
    }  # fmt: skip
    assert natural_interaction(app, wizard).natural_source == "synthetic"


def test_a_switch_sends_only_what_changed_and_the_console_agrees(
    pi: StaffApi, study_id: int, worker: Worker, bridge: Bridge
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.switch_condition("still", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "robot.applied")
    wizard.switch_condition("copy", 1)
    switched = until(
        lambda: [e for e in timeline(wizard) if e["kind"] == "robot.applied"][1:],
        what="the set-up after the switch",
    )[0]
    assert switched["payload"]["behaviour"]["sent"] is True
    assert "unchanged" not in switched["payload"]["behaviour"]
    assert switched["payload"]["face_result"]["unchanged"] is True  # not re-sent
    assert bridge.state(BOOTH).behaviour == {"name": "copy", "params": {"delay": 4.0}}
    # The console's own set-up of the same interaction targets the same state.
    console = wizard.staff.post(f"/api/wizard/sessions/{wizard.session_id}/robot/apply")
    assert (console["kind"], console["condition"]) == ("robot.applied", "copy")
    assert bridge.state(BOOTH).behaviour == {"name": "copy", "params": {"delay": 4.0}}
