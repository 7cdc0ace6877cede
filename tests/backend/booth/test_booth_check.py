"""The booth check: each step judged against the expected sign and size, and the whole
check through a real bridge and worker fed a head turn and nod over real Live Link UDP."""

from __future__ import annotations

import os
import threading
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest
from fastapi import FastAPI
from sqlalchemy import select

from chameleons.backend.booth import check
from chameleons.backend.bridge import Bridge
from chameleons.backend.models import BoothCheck
from chameleons.settings import Settings
from chameleons.worker.runtime import Worker
from tests.backend.booth.conftest import (
    BOOTH,
    new_session,
    running_worker,
    timeline,
    until,
    worker_config,
)
from tests.support.bots import StaffApi
from tests.worker.head_stream import Pose, stream_after


@pytest.fixture
def settings(settings: Settings) -> Settings:
    """A shorter head movement than a technician's (the replayed turn and nod take 3 s)."""
    return settings.model_copy(update={"booth_check_rest_seconds": 1.0,
                                       "booth_check_turn_seconds": 2.5,
                                       "booth_check_nod_seconds": 2.0})  # fmt: skip


def beat(yaw: tuple[float, float], pitch_max: float, rest: tuple[float, float] = (0.0, 0.0),
         **extra: Any) -> dict[str, Any]:  # fmt: skip
    heads = {"yaw_min": yaw[0], "yaw_max": yaw[1], "pitch_min": 0.0, "pitch_max": pitch_max,
             "frames": 480, "rest": {"yaw": rest[0], "pitch": rest[1], "frames": 60,
                                     "seconds": 1.0}}  # fmt: skip
    return {"input_fps": 60.0, "capture_to_send_ms": 9.0, "ingest": {"head_range": heads},
            **extra}  # fmt: skip


def test_a_left_turn_and_a_nod_of_the_right_size_pass() -> None:
    result = check.head_turn(beat((-2.0, 41.0), 14.0))
    assert result["status"] == "pass"
    assert result["figures"]["turn_deg"] == 41.0
    assert result["value"] == (
        "turn +41° (expected +20..+90: turn left), nod +14° (expected +8..+60), from a resting "
        "pose of yaw +0°, pitch +0°"
    )


@pytest.mark.parametrize(
    ("yaw", "pitch_max", "rest", "why"),
    [((24.0, 27.0), 40.0, (25.0, 0.0), "no turn to the left seen"),  # a phone 25° aside
     ((-2.0, 41.0), 16.0, (0.0, 14.7), "no nod seen"),  # a phone below the face
     ((23.0, 66.0), 30.0, (25.0, 14.7), None)],  # both, with the movement: it passes
)  # fmt: skip
def test_the_movement_is_judged_from_the_resting_pose_not_from_zero(
    yaw: tuple[float, float], pitch_max: float, rest: tuple[float, float], why: str | None
) -> None:
    result = check.head_turn(beat(yaw, pitch_max, rest))
    assert result["status"] == ("pass" if why is None else "fail"), result
    assert why is None or why in result["value"]
    assert (result["figures"]["rest_yaw"], result["figures"]["rest_pitch"]) == rest


def test_a_turn_the_wrong_way_shows_the_negative_turn_against_the_expected_sign() -> None:
    result = check.head_turn(beat((-41.0, 2.0), 14.0))
    assert result["value"].startswith("turn -41° (expected +20..+90: turn left)")


def test_without_head_frames_or_a_resting_pose_the_step_says_what_it_expects() -> None:
    result = check.head_turn({"input_fps": 60.0})
    assert result["status"] == "fail"
    assert "expected yaw +20..+90° (a turn to the left) and pitch +8..+60°" in result["value"]
    unmarked = beat((-2.0, 41.0), 14.0)
    unmarked["ingest"]["head_range"]["rest"] = None
    assert "no resting pose measured" in check.head_turn(unmarked)["value"]


def test_a_timecode_the_worker_does_not_trust_is_a_warning_with_the_reason() -> None:
    telemetry = beat((-2.0, 41.0), 14.0)
    telemetry["ingest"]["timecode_problem"] = "the phone's timecode is frozen"
    face = check.face_stream(telemetry)
    assert face["status"] == "warn"
    assert face["value"] == ("60 fps, 9 ms to the robot; the phone's timecode is frozen: the "
                             "copy runs on arrival times (check the phone app's timecode "
                             "source)")  # fmt: skip


def copy_beat(behaviour: str, measured: float | None) -> dict[str, Any]:
    probe = None if measured is None else {"delay_s": measured, "correlation": 0.97}
    return {"behaviour": behaviour, "behaviour_params": {"delay": 4.0}, "movement_delay": probe}


@pytest.mark.parametrize(
    ("movement", "status", "why"),
    [(None, "fail", "not run"),
     (check.Movement(4.0, "copy", copy=copy_beat("copy", 4.1)), "pass", "4.10 s measured"),
     (check.Movement(4.0, "copy", copy=copy_beat("copy", 4.3)), "fail", "+300 ms"),
     (check.Movement(4.0, "copy", copy=copy_beat("copy", 3.7)), "fail", "-300 ms"),
     (check.Movement(4.0, "copy", copy=copy_beat("copy", None)), "fail", "did not copy"),
     (check.Movement(4.0, "copy", copy=copy_beat("still", None)), "fail", "ran still"),
     (check.Movement(4.0, None, problem="The worker refused: bad_behaviour"), "fail",
      "could not be switched to copy")],
)  # fmt: skip
def test_the_copy_step_fails_when_the_robot_does_not_copy_or_the_delay_is_off(
    movement: check.Movement | None, status: str, why: str
) -> None:
    result = check.copies({"input_fps": 60.0}, movement)
    assert result["status"] == status, result
    assert why in result["value"]
    if movement is not None and status == "pass":
        assert result["figures"]["tolerance_s"] == check.MAX_DELAY_ERROR_S
        assert "allowed ±250 ms" in result["value"]


@pytest.mark.parametrize(
    ("yaw", "pitch", "why"),
    [((-41.0, 2.0), 14.0, "wrong way"), ((-3.0, 125.0), 44.0, "rotation unit"),
     ((-1.0, 4.0), 14.0, "no turn"), ((-1.0, 40.0), 1.0, "no nod")],
)  # fmt: skip
def test_sign_unit_and_missing_movement_errors_are_named(
    yaw: tuple[float, float], pitch: float, why: str
) -> None:
    result = check.head_turn(beat(yaw, pitch))
    assert result["status"] == "fail"
    assert why in result["value"]


def test_without_a_worker_every_worker_step_fails_and_disk_is_judged(tmp_path: Path) -> None:
    result = check.run(None, None, tmp_path)
    steps = {s["id"]: s for s in result["steps"]}
    assert result["passed"] is False
    assert steps["face"]["value"] == "no worker for this booth"
    assert steps["disk"]["status"] == "pass" or "below" in steps["disk"]["value"]
    assert check.disk(tmp_path, minimum=2**62)["status"] == "warn"  # a free-space warning


def test_the_disk_step_needs_a_session_of_recordings_and_a_writable_folder(
    tmp_path: Path,
) -> None:
    from chameleons.settings import Settings

    settings = Settings(recording_rate_bytes_per_s=1_000, session_length_minutes=30)
    assert settings.session_disk_bytes == 1_800_000  # rate x session length
    enough = check.disk(tmp_path, settings.session_disk_bytes)
    assert enough["status"] == "pass"
    assert enough["figures"]["needed_bytes"] == 1_800_000
    assert "a session needs about 2 MB" in enough["value"]
    short = check.disk(tmp_path, minimum=2**62)
    assert short["status"] == "warn"
    assert "below the" in short["value"]
    if os.geteuid() != 0:  # root writes through permissions (the reliability suite mounts)
        (tmp_path / "recordings").mkdir()
        (tmp_path / "recordings").chmod(0o555)
        try:
            refused = check.disk(tmp_path)
        finally:
            (tmp_path / "recordings").chmod(0o755)
        assert refused["status"] == "fail"
        assert "is read-only" in refused["value"]


def check_in_background(
    pi: StaffApi, path: str
) -> tuple[threading.Thread, dict[str, Any]]:  # fmt: skip
    """POST the check from another thread (it runs for the head movement and the copy)."""
    answer: dict[str, Any] = {}

    def run() -> None:
        try:
            answer.update(pi.post(path))
        except Exception as exc:  # reported by the test, not lost in the thread
            answer["error"] = repr(exc)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    return thread, answer


def acknowledged_behaviour(bridge: Bridge) -> dict[str, Any] | None:
    return bridge.state(BOOTH).behaviour


def running_behaviour(bridge: Bridge) -> Any:
    return (bridge.latest_telemetry(BOOTH)[0] or {}).get("behaviour")


def phone_ready(worker: Worker) -> Callable[[], bool]:
    """The check has taken the resting pose (its "hold still" is over): move now."""
    return lambda: worker.receivers["livelink"].stats.rest_marked_at is not None


# A phone below the face and 25 degrees aside: the resting pose is not zero.
OFF_CENTRE = {"rest_yaw": 25.0, "rest_pitch": 14.7}
TURN_AND_NOD = Pose(**OFF_CENTRE, turn_at=0.3, turn_deg=40.0, turn_s=1.5, nod_at=2.0,
                    nod_deg=15.0, nod_s=1.0)  # fmt: skip


@pytest.mark.usefixtures("flow")
def test_the_check_through_a_real_worker_in_still_runs_the_robot_in_copy_and_restores_it(
    app: FastAPI, pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    """The phone sits below the face and aside; the technician holds still, turns and
    nods: the movement is measured from that resting pose and passes."""
    wizard, _ = new_session(pi, study_id)
    config = worker_config(bridge, tmp_path, livelink_port=0)
    assert config.behaviour == "still"  # a worker between participants
    with running_worker(bridge, config) as worker:
        until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
        checking, answer = check_in_background(
            pi, f"/api/booths/{BOOTH}/check?session_id={wizard.session_id}"
        )
        # The check switches the robot to copy with the study's delay; then the head turns.
        until(lambda: acknowledged_behaviour(bridge) == {"name": "copy", "params": {"delay": 4.0}},
              what="the check's switch to copy")  # fmt: skip
        stream_after(worker.receivers["livelink"].port, TURN_AND_NOD, 3.5, phone_ready(worker),
                     until=lambda: not checking.is_alive())  # fmt: skip
        checking.join(timeout=90)
        assert not checking.is_alive()
        assert "error" not in answer, answer
        # Restored: the worker runs still again, as before the check.
        assert acknowledged_behaviour(bridge) == {"name": "still"}
        until(lambda: running_behaviour(bridge) == "still", what="still restored")
        # The copied head was re-centred on the rest held still during the check, and is
        # measured afresh after it (a participant is never copied on the technician's pose).
        neutral = worker.behaviour.router.context.head_neutral
        assert (neutral.how, neutral.restarts) == ("calibrating", 1)
    steps = {s["id"]: s for s in answer["steps"]}
    head = steps["head"]
    assert head["status"] == "pass", head
    assert head["figures"]["rest_yaw"] == pytest.approx(25.0, abs=0.2)
    assert head["figures"]["rest_pitch"] == pytest.approx(14.7, abs=0.2)
    assert 38.0 < head["figures"]["turn_deg"] <= 40.5
    assert 13.0 < head["figures"]["nod_deg"] <= 15.5
    assert "(expected +20..+90: turn left)" in head["value"]
    assert head["value"].endswith("from a resting pose of yaw +25°, pitch +15°")
    assert steps["robot"]["status"] == "pass"
    copy = steps["copy"]
    assert (copy["figures"]["delay_s"], copy["figures"]["condition"]) == (4.0, "copy")
    assert copy["status"] == "pass", copy
    assert abs(copy["figures"]["measured_s"] - 4.0) <= check.MAX_DELAY_ERROR_S
    face = steps["face"]  # the copy's 4 s is not latency (it read "3993 ms to the robot")
    assert face["status"] == "pass", face
    assert face["figures"]["latency_ms"] < check.MAX_LATENCY_MS
    assert [s["id"] for s in answer["steps"]] == ["face", "head", "robot", "copy", "speech",
                                                   "disk"]  # fmt: skip
    stored = next(e for e in timeline(wizard) if e["kind"] == "booth.checked")
    assert stored["payload"]["steps"] == answer["steps"]
    with app.state.sessionmaker() as db:
        row = db.scalars(select(BoothCheck).where(BoothCheck.session_id == wizard.session_id)).one()
    assert row.measured_delay_s == copy["figures"]["measured_s"]
    assert (row.copy_delay_s, row.booth, row.passed) == (4.0, BOOTH, answer["passed"])
    assert row.head_yaw_deg == head["figures"]["turn_deg"]


@pytest.mark.parametrize(
    ("pose", "why"),
    [(Pose(rest_pitch=14.7, turn_at=0.3, turn_deg=40.0, turn_s=1.5), "no nod seen"),
     (Pose(rest_yaw=25.0, nod_at=0.3, nod_deg=15.0, nod_s=1.0), "no turn to the left seen")],
    ids=["phone-below-no-nod", "phone-aside-no-turn"],
)  # fmt: skip
@pytest.mark.usefixtures("flow")
def test_a_phone_off_centre_is_no_nod_or_turn(
    pi: StaffApi, bridge: Bridge, tmp_path: Path, pose: Pose, why: str
) -> None:
    """A phone 15 degrees below the face (or 25 aside) passed the nod (the turn) before the
    movement was judged from the resting pose."""
    with running_worker(bridge, worker_config(bridge, tmp_path, livelink_port=0)) as worker:
        until(lambda: running_behaviour(bridge) == "still", what="the worker in still")
        checking, answer = check_in_background(pi, f"/api/booths/{BOOTH}/check?say=false")
        stream_after(worker.receivers["livelink"].port, pose, 2.5, phone_ready(worker))
        checking.join(timeout=90)
    assert "error" not in answer, answer
    head = next(s for s in answer["steps"] if s["id"] == "head")
    assert head["status"] == "fail", head
    assert why in head["value"]
    assert answer["passed"] is False


@pytest.mark.usefixtures("flow")
def test_a_robot_that_does_not_copy_fails_the_step_and_its_behaviour_is_restored(
    pi: StaffApi, study_id: int, bridge: Bridge, tmp_path: Path
) -> None:
    """Nobody turns the head: no copy is measured, so the step fails (it is not a warning
    and the booth is not ready), and the behaviour from before (natural) comes back."""
    config = worker_config(bridge, tmp_path, behaviour="natural", livelink_port=0,
                           behaviour_params={"seed": 3})  # fmt: skip
    with running_worker(bridge, config):
        until(lambda: running_behaviour(bridge) == "natural", what="the worker in natural")
        result = pi.post(f"/api/booths/{BOOTH}/check?say=false")
        assert acknowledged_behaviour(bridge) == {"name": "natural", "params": {"seed": 3}}
        until(lambda: running_behaviour(bridge) == "natural", what="natural restored")
    copy = next(s for s in result["steps"] if s["id"] == "copy")
    assert copy["status"] == "fail"
    assert "the robot did not copy the head movement" in copy["value"]
    assert result["passed"] is False


@pytest.mark.usefixtures("flow", "worker")
def test_the_check_is_refused_while_a_participants_interaction_runs_on_the_booth(
    pi: StaffApi, study_id: int, bridge: Bridge
) -> None:
    wizard, _ = new_session(pi, study_id)
    wizard.start()
    wizard.advance(1, "discussion")
    response = pi.http.post(f"/api/booths/{BOOTH}/check", json={},
                            headers={"X-CSRF-Token": pi.csrf})  # fmt: skip
    assert response.status_code == 409
    assert "Interaction 1 of session" in response.json()["detail"]
    assert "would take the robot from the participant" in response.json()["detail"]
    assert not any(e["kind"] == "booth.checked" for e in timeline(wizard))


def test_a_check_without_a_session_is_stored_with_the_study_of_the_booth(
    app: FastAPI, pi: StaffApi, study_id: int
) -> None:
    """No worker: judged at once. The study is the booth's latest session's, so its export
    has the check (with no participant or session); the plan names the study's delay."""
    new_session(pi, study_id)
    plan = pi.get(f"/api/booths/{BOOTH}/check")
    assert (plan["copy_delay_s"], plan["copy_condition"], plan["study_id"]) == (
        4.0, "copy", study_id,
    )  # fmt: skip
    assert [p["id"] for p in plan["prompts"]] == ["rest", "turn", "nod", "copy"]
    result = pi.post(f"/api/booths/{BOOTH}/check")
    assert result["passed"] is False
    with app.state.sessionmaker() as db:
        row = db.scalars(select(BoothCheck)).one()
    assert (row.session_id, row.study_id) == (None, study_id)


def test_the_check_restores_the_start_behaviour_a_heartbeat_did_not_name_yet() -> None:
    """A worker's first heartbeats come before its behaviour stage reports: with nothing set
    through the server either, the behaviour to restore after the check's copy is the one
    the worker said hello with (the robot went on copying after the check before)."""
    from chameleons.backend.booth.check_run import _running_behaviour
    from chameleons.backend.bridge.state import WorkerInfo
    from chameleons.worker.control import SET_BEHAVIOUR

    bridge = Bridge()  # never started: no sockets
    early = {"behaviour": None, "behaviour_params": None}
    assert _running_behaviour(bridge, "booth-1", early) == {"name": "still"}  # no hello yet
    bridge._workers["booth-1"] = WorkerInfo("booth-1", "first", {"behaviour": "natural"})
    assert _running_behaviour(bridge, "booth-1", early) == {"name": "natural"}
    bridge.state("booth-1").record(SET_BEHAVIOUR, {"name": "copy", "params": {"delay": 4}})
    assert _running_behaviour(bridge, "booth-1", early) == {"name": "copy", "params": {"delay": 4}}
    reported = {"behaviour": "mirror", "behaviour_params": {"gain": 1}}
    assert _running_behaviour(bridge, "booth-1", reported) == {"name": "mirror",
                                                              "params": {"gain": 1}}  # fmt: skip
