"""The booth check on a booth with both robots (``--driver virtual+furhat``, the
``embodiment`` template): the check of a condition runs on that condition's robot (its
``renderer``), says which robot it checked, and puts the booth's face and renderer back.
A Furhat condition on a booth without a Furhat is refused in one sentence at once.
Through a real bridge and worker fed a head turn and nod over real Live Link UDP, the
display's frames read from the bridge and the Furhat test peer's head poses."""

from __future__ import annotations

import time
from functools import partial
from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient

from chameleons.backend.bridge import Bridge
from chameleons.settings import Settings
from chameleons.worker.control import SET_FACE
from chameleons.worker.envelope import Message
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import BOOTH, new_session, running_worker, until, worker_config
from tests.backend.booth.test_booth_check import (
    TURN_AND_NOD,
    acknowledged_behaviour,
    check_in_background,
    running_behaviour,
)
from tests.experiment.study_files import default_document, study_yaml
from tests.support.bots import StaffApi, study_with_plan
from tests.worker.furhat_peer import FurhatPeer
from tests.worker.head_stream import stream_after

pytestmark = pytest.mark.slow
DELAY = {"delay": 1.0}
TURN = 40.0  # TURN_AND_NOD's turn, copied from the rest held still (re-centred)
# As the last interaction left the booth: the display's 3D head.
BEFORE = {"face_id": "face-2", "renderer": "3d"}


@pytest.fixture
def settings(settings: Settings) -> Settings:
    return settings.model_copy(update={"booth_check_rest_seconds": 1.0,
                                       "booth_check_turn_seconds": 2.5,
                                       "booth_check_nod_seconds": 2.0})  # fmt: skip


@pytest.fixture
def embodiment_study(pi: StaffApi) -> int:
    document = default_document()
    document["conditions"] = {
        "copy_2d": {"label": "Copy, flat face", "behaviour": "copy", "renderer": "2d",
                    "params": DELAY},
        "copy_furhat": {"label": "Copy, Furhat", "behaviour": "copy", "renderer": "furhat",
                        "params": DELAY},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_with_plan(pi, participants=6, yaml=study_yaml(document))


def set_face(client: TestClient, bridge: Bridge, body: dict[str, Any]) -> None:
    assert client.portal is not None
    ack = client.portal.call(partial(bridge.send_command, BOOTH, SET_FACE, body, timeout=3.0))
    assert ack.ok, ack


def face(bridge: Bridge) -> dict[str, Any] | None:
    return bridge.state(BOOTH).face


def heartbeat(bridge: Bridge) -> dict[str, Any]:
    return bridge.latest_telemetry(BOOTH)[0] or {}


def display_yaws(frames: list[Message], since: float, until_: float) -> list[float]:
    return [abs(float(m.body["yaw"])) for m in frames
            if m.type == "head" and since <= m.time <= until_]  # fmt: skip


def furhat_yaws(robot: FurhatPeer, since: float, until_: float) -> list[float]:
    return [abs(float(r.message["yaw"])) for r in robot.of_type("request.face.headpose")
            if since <= r.time <= until_]  # fmt: skip


def run_on(pi: StaffApi, bridge: Bridge, worker: Worker, condition: str,
           renderer: str) -> tuple[dict[str, Any], float, float]:  # fmt: skip
    """Check ``condition`` with a head turn and nod; returns the answer, when the booth was
    on the condition's robot (monotonic) and when the check ended."""
    stats = worker.receivers["livelink"].stats
    asked = time.monotonic()
    checking, answer = check_in_background(
        pi, f"/api/booths/{BOOTH}/check?say=false&condition={condition}"
    )
    until(lambda: face(bridge) == {"face_id": BEFORE["face_id"], "renderer": renderer},
          what=f"the check's switch to {renderer}")  # fmt: skip
    switched = time.monotonic()
    until(lambda: acknowledged_behaviour(bridge) == {"name": "copy", "params": DELAY},
          what="the check's switch to copy")  # fmt: skip
    rested = lambda: (stats.rest_marked_at or float("-inf")) > asked  # noqa: E731
    stream_after(worker.receivers["livelink"].port, TURN_AND_NOD, 3.5, rested,
                 until=lambda: not checking.is_alive())  # fmt: skip
    checking.join(timeout=90)
    assert not checking.is_alive()
    assert "error" not in answer, answer
    return answer, switched, time.monotonic()


@pytest.mark.usefixtures("flow")
def test_the_check_runs_on_the_conditions_robot_and_puts_the_booth_back(
    client: TestClient, pi: StaffApi, embodiment_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    new_session(pi, embodiment_study)  # the booth's study
    frames: list[Message] = []
    bridge.add_listener("display.", frames.append)
    with FurhatPeer() as robot:
        config = worker_config(bridge, tmp_path, livelink_port=0, driver="virtual+furhat",
                               robot_url=robot.url)  # fmt: skip
        with running_worker(bridge, config) as worker:
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
            set_face(client, bridge, BEFORE)
            on_furhat, start, end = run_on(pi, bridge, worker, "copy_furhat", "furhat")
            # Put back: the display's 3D head, in still, the display driven again.
            assert face(bridge) == BEFORE
            assert acknowledged_behaviour(bridge) == {"name": "still"}
            until(lambda: heartbeat(bridge).get("robot_active") == "display",
                  what="the display driven again")  # fmt: skip
            # The Furhat's head copied the turn; the display's stayed at its neutral while
            # the Furhat ran, and after the check put the booth back on the display (its
            # set_face) it woke from that neutral into still: it never showed the tail of
            # the Furhat's copy, which the behaviour crossfade into still runs through
            # (before the switch's hold it swung the display's head 15-18 deg here).
            assert max(furhat_yaws(robot, start, end)) == pytest.approx(TURN, abs=2.5)
            back = min(m.time for m in frames if m.type == "set_face" and m.time > start)
            woken = back + config.switch_hold_seconds + config.switch_fade_seconds + 0.2
            until(lambda: any(m.time > woken for m in frames if m.type == "head"),
                  what="the display's frames after its wake")  # fmt: skip
            assert max(display_yaws(frames, start + 0.5, woken), default=0.0) < 0.5

            on_display, start, end = run_on(pi, bridge, worker, "copy_2d", "2d")
            assert face(bridge) == BEFORE
            until(lambda: running_behaviour(bridge) == "still", what="still restored")
            assert max(display_yaws(frames, start, end)) == pytest.approx(TURN, abs=2.5)
            assert max(furhat_yaws(robot, start + 0.5, end), default=0.0) < 0.5

    assert on_furhat["checked_on"] == "Checked on the Furhat"
    steps = {s["id"]: s for s in on_furhat["steps"]}
    assert steps["copy"]["status"] == "pass", steps["copy"]
    assert "; checked on the Furhat" in steps["copy"]["value"]
    assert steps["copy"]["figures"]["robot"] == "the Furhat"
    assert (steps["robot"]["status"], steps["robot"]["value"]) == ("pass", "the Furhat: connected")

    assert on_display["checked_on"] == "Checked on the display's 2D face"
    steps = {s["id"]: s for s in on_display["steps"]}
    assert steps["copy"]["status"] == "pass", steps["copy"]
    assert "; checked on the display's 2D face" in steps["copy"]["value"]
    # The display is judged by its page (none is open in this test), not by the Furhat.
    assert steps["robot"] == {
        **steps["robot"],
        "status": "fail",
        "value": "the display's 2D face: no robot display open",
    }


@pytest.mark.usefixtures("flow")
def test_a_furhat_condition_on_a_booth_without_a_furhat_is_refused_in_one_sentence(
    client: TestClient, pi: StaffApi, embodiment_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    """Nothing is sent to the worker (its face and behaviour stay), and the steps that
    need the Furhat fail with the sentence at once (no head movement is waited for)."""
    new_session(pi, embodiment_study)
    assert pi.get(f"/api/booths/{BOOTH}/check?condition=copy_furhat")["renderer"] == "furhat"
    page = pi.http.get(f"/booths/{BOOTH}/check?condition=copy_furhat").text
    assert 'Like the condition, it runs on <strong id="check-renderer">the Furhat' in page
    config = worker_config(bridge, tmp_path, livelink_port=0, driver="virtual")
    with running_worker(bridge, config):
        until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
        set_face(client, bridge, BEFORE)
        answer = pi.post(f"/api/booths/{BOOTH}/check?condition=copy_furhat")
        assert face(bridge) == BEFORE
        assert acknowledged_behaviour(bridge) is None  # never switched to copy
    sentence = ("copy_furhat runs on the Furhat, and this booth's worker drives no Furhat "
                "(its driver is virtual): start it with --driver virtual+furhat (or --driver "
                "furhat) to check this condition")  # fmt: skip
    steps = {s["id"]: s for s in answer["steps"]}
    assert answer["passed"] is False
    assert answer["checked_on"] == f"Not checked on the Furhat: {sentence}"
    assert answer["robot"]["problem"] == sentence
    assert (steps["robot"]["status"], steps["robot"]["value"]) == ("fail", sentence)
    assert (steps["copy"]["status"], steps["copy"]["value"]) == ("fail", f"not run: {sentence}")
    assert (steps["speech"]["status"], steps["speech"]["value"]) == ("fail", f"not run: {sentence}")


@pytest.mark.usefixtures("flow")
def test_an_interaction_that_starts_during_the_check_keeps_its_own_robot(
    client: TestClient, pi: StaffApi, embodiment_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    """The check does not put the booth's face back over the set-up of an interaction that
    started meanwhile: that interaction's face and robot stay."""
    wizard, _ = new_session(pi, embodiment_study)
    first = wizard.interaction(1)
    renderer = {"copy_2d": "2d", "copy_furhat": "furhat"}.get(first["condition"])
    own = {"face_id": first["face"], **({"renderer": renderer} if renderer else {})}
    checked, on = ("copy_2d", "2d") if renderer == "furhat" else ("copy_furhat", "furhat")
    with FurhatPeer() as robot:
        config = worker_config(bridge, tmp_path, livelink_port=0, driver="virtual+furhat",
                               robot_url=robot.url)  # fmt: skip
        with running_worker(bridge, config):
            robot.wait_for(lambda p: bool(p.of_type("request.face.config")), timeout=10)
            until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
            set_face(client, bridge, BEFORE)
            checking, answer = check_in_background(
                pi, f"/api/booths/{BOOTH}/check?say=false&condition={checked}"
            )
            until(lambda: face(bridge) == {"face_id": BEFORE["face_id"], "renderer": on},
                  what=f"the check's switch to {on}")  # fmt: skip
            wizard.start()
            wizard.advance(1, "discussion")
            until(lambda: face(bridge) == own, what="the interaction's own set-up")
            checking.join(timeout=90)
            assert not checking.is_alive()
            assert "error" not in answer, answer
            assert face(bridge) == own
            expected = "furhat" if renderer == "furhat" else "display"
            until(lambda: heartbeat(bridge).get("robot_active") == expected,
                  what="the interaction's robot driven")  # fmt: skip


@pytest.fixture
def plain_copy_study(pi: StaffApi) -> int:
    """A copy condition that names no robot beside the Furhat's."""
    document = default_document()
    document["conditions"] = {
        "copy_plain": {"label": "Copy", "behaviour": "copy", "params": DELAY},
        "copy_furhat": {"label": "Copy, Furhat", "behaviour": "copy", "renderer": "furhat",
                        "params": DELAY},
        "still": {"label": "Still", "behaviour": "still"},
    }  # fmt: skip
    return study_with_plan(pi, participants=6, yaml=study_yaml(document))


@pytest.mark.usefixtures("flow")
def test_a_condition_without_a_renderer_is_checked_on_the_display_as_a_session_runs_it(
    client: TestClient, pi: StaffApi, plain_copy_study: int, bridge: Bridge, tmp_path: Path
) -> None:
    """The Furhat runs now; a condition naming no robot runs on the display in a session
    (its face is sent without a renderer), so the check puts the booth there and back."""
    new_session(pi, plain_copy_study)
    on_furhat = {"face_id": "face-2", "renderer": "furhat"}
    frames: list[Message] = []
    bridge.add_listener("display.", frames.append)
    with FurhatPeer() as robot:
        config = worker_config(bridge, tmp_path, livelink_port=0, driver="virtual+furhat",
                               robot_url=robot.url)  # fmt: skip
        with running_worker(bridge, config):
            until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
            set_face(client, bridge, on_furhat)
            answer = pi.post(f"/api/booths/{BOOTH}/check?condition=copy_plain&say=false"
                             "&movement=false")  # fmt: skip
            assert face(bridge) == on_furhat
            until(lambda: heartbeat(bridge).get("robot_active") == "furhat",
                  what="the Furhat driven again")  # fmt: skip
    # The display was given the face (no renderer: the page keeps its own) for the check.
    assert [m.body for m in frames if m.type == "set_face"] == [{"face_id": "face-2"}]
    assert answer["checked_on"] == "Checked on the display"
    robot_step = next(s for s in answer["steps"] if s["id"] == "robot")
    assert robot_step["value"] == "the display: no robot display open"
