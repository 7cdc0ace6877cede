"""The health checks from the worker's telemetry, and how long each has been failing."""

from __future__ import annotations

from pathlib import Path

import pytest

from chameleons.backend.wizard.health import Check, HealthTracker, Thresholds, evaluate, tracker_of
from chameleons.settings import Settings

# The fields of the worker's heartbeat (chameleons.worker.hub.ControlHub.status).
GOOD = {
    "input_fps": 59.8,
    "tick_rate_hz": 124.9,
    "jitter_ms": {"p50": 0.1, "p99": 0.4, "max": 0.9},
    "robot_connected": True,
    "speaking": False,
}


def test_good_telemetry_passes_every_check() -> None:
    checks = evaluate(GOOD, age=0.5)
    assert all(check.ok for check in checks.values())
    assert checks["tick"].value == "124.9 Hz"
    assert checks["speaking"].value == "quiet"


def test_each_failure_is_its_own_check() -> None:
    bad = {**GOOD, "input_fps": 3.0, "tick_rate_hz": 90.0, "jitter_ms": {"p99": 6.0}}
    bad["robot_connected"] = False
    checks = evaluate(bad, age=0.5)
    failing = sorted(name for name, check in checks.items() if check.ok is False)
    assert failing == ["input", "jitter", "robot", "tick"]


def test_stale_telemetry_means_the_worker_is_gone() -> None:
    checks = evaluate(GOOD, age=4.0)
    assert checks["worker"].ok is False
    assert checks["worker"].value == "silent 4 s"
    assert checks["robot"].ok is None


def test_failing_time_counts_from_the_first_failure_and_resets_on_recovery() -> None:
    tracker = HealthTracker()
    first = tracker.snapshot("b1", None, None, now=100.0)
    later = tracker.snapshot("b1", None, None, now=112.5)
    worker = next(c for c in later["checks"] if c["id"] == "worker")
    assert first["ok"] is False
    assert worker["failing_for"] == 12.5
    recovered = tracker.snapshot("b1", GOOD, 0.2, now=113.0)
    assert recovered["ok"] is True
    again = tracker.snapshot("b1", None, None, now=120.0)
    assert next(c for c in again["checks"] if c["id"] == "worker")["failing_for"] == 0.0


def test_booths_are_tracked_apart() -> None:
    tracker = HealthTracker()
    tracker.snapshot("b1", None, None, now=0.0)
    other = tracker.snapshot("b2", None, None, now=30.0)
    assert next(c for c in other["checks"] if c["id"] == "worker")["failing_for"] == 0.0


def _check(snapshot: dict[str, object], check_id: str) -> dict[str, object]:
    checks = snapshot["checks"]
    assert isinstance(checks, list)
    found: dict[str, object] = next(c for c in checks if c["id"] == check_id)
    return found


def test_a_measured_3_ms_jitter_passes_the_default_limit() -> None:
    """A bare Python loop on the 2-core lab PC measures ~3 ms p99 (docs/performance.md)."""
    checks = evaluate({**GOOD, "jitter_ms": {"p99": 3.1}}, age=0.5)
    assert checks["jitter"].ok is True


def test_a_degraded_check_turns_into_an_alarm_after_the_grace_period() -> None:
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=3.0))
    slow = {**GOOD, "input_fps": 12.0}
    first = tracker.snapshot("b1", slow, 0.2, now=10.0)
    assert _check(first, "input")["level"] == "degraded"
    assert (first["ok"], first["alarm"]) == (False, False)
    still = tracker.snapshot("b1", slow, 0.2, now=12.9)
    assert _check(still, "input")["level"] == "degraded"
    late = tracker.snapshot("b1", slow, 0.2, now=13.0)
    assert _check(late, "input")["level"] == "alarm"
    assert _check(late, "input")["failing_for"] == 3.0
    assert late["alarm"] is True
    recovered = tracker.snapshot("b1", GOOD, 0.2, now=14.0)
    assert _check(recovered, "input")["level"] == "ok"
    again = tracker.snapshot("b1", slow, 0.2, now=15.0)
    assert _check(again, "input")["level"] == "degraded"


@pytest.mark.parametrize(
    ("telemetry", "check_id"), [(None, "worker"), ({**GOOD, "robot_connected": False}, "robot")]
)
def test_a_lost_worker_or_robot_is_an_alarm_at_once(
    telemetry: dict[str, object] | None, check_id: str
) -> None:
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=30.0))
    snapshot = tracker.snapshot("b1", telemetry, 0.2 if telemetry else None, now=0.0)
    assert _check(snapshot, check_id)["level"] == "alarm"
    assert snapshot["alarm"] is True


def test_the_limits_come_from_the_settings(tmp_path: Path) -> None:
    settings = Settings(data_dir=tmp_path, health_max_jitter_p99_ms=1.0, health_min_face_fps=50.0,
                        health_min_tick_ratio=0.5, health_alarm_after_s=0.0)  # fmt: skip

    class State:
        pass

    state = State()
    state.settings = settings  # type: ignore[attr-defined]
    tracker = tracker_of(state)
    assert tracker.limits == Thresholds(1.0, 50.0, 0.5, 0.0)
    telemetry = {**GOOD, "jitter_ms": {"p99": 3.1}, "tick_rate_hz": 70.0}
    snapshot = tracker.snapshot("b1", telemetry, 0.2, now=0.0)
    levels = {c["id"]: c["level"] for c in snapshot["checks"]}
    assert (levels["jitter"], levels["input"], levels["tick"]) == ("alarm", "ok", "ok")


def test_the_limit_settings_are_read_from_the_environment(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setenv("CHAMELEONS_HEALTH_MAX_JITTER_P99_MS", "7.5")
    monkeypatch.setenv("CHAMELEONS_HEALTH_ALARM_AFTER_S", "10")
    limits = Thresholds.from_settings(Settings(data_dir=tmp_path))
    assert (limits.max_jitter_p99_ms, limits.alarm_after_s) == (7.5, 10.0)


def test_a_refused_robot_login_shows_the_reason_on_the_robot_chip() -> None:
    telemetry = {**GOOD, "robot_connected": False, "robot_state": "auth_refused",
                 "robot_problem": "the robot refused the login (wrong or missing key)"}  # fmt: skip
    robot = evaluate(telemetry, age=0.5)["robot"]
    assert robot.ok is False
    assert robot.value == "login refused: the robot refused the login (wrong or missing key)"
    plain = evaluate({**GOOD, "robot_connected": False, "robot_state": "connecting"}, age=0.5)
    assert plain["robot"].value == "disconnected"


def test_a_robot_the_worker_tries_again_says_when_on_the_robot_chip() -> None:
    """An unanswered login (a robot still booting) and a lost connection are retried by the
    worker with backoff: the chip says when the next try is, and that one is under way."""
    why = "the robot did not answer the login within 5 s"
    waiting = {**GOOD, "robot_connected": False, "robot_state": "auth_timeout",
               "robot_problem": why, "robot_retry_in": 7.6}  # fmt: skip
    robot = evaluate(waiting, age=0.5)["robot"]
    assert robot.value == f"login not answered: {why}; retrying in 8 s"
    trying = {**waiting, "robot_state": "connecting", "robot_retry_in": None}
    assert evaluate(trying, age=0.5)["robot"].value == f"login failed: {why}; trying again now"
    lost = {**GOOD, "robot_connected": False, "robot_state": "disconnected", "robot_retry_in": 2}
    assert evaluate(lost, age=0.5)["robot"].value == "disconnected; retrying in 2 s"


def test_an_unmapped_study_face_or_a_refused_face_field_gets_a_chip_of_its_own() -> None:
    assert "face" not in evaluate({**GOOD, "robot_face": {"unmapped_face": None}}, age=0.5)
    telemetry = {**GOOD, "robot_face": {"unmapped_face": "face-3",
                                        "refused": {"head_sway": "unknown field"}}}  # fmt: skip
    snapshot = HealthTracker().snapshot("b1", telemetry, 0.5, now=1.0)
    face = next(c for c in snapshot["checks"] if c["id"] == "face")
    assert face["label"] == "Robot face"
    assert face["ok"] is False
    assert face["value"] == "face-3 not mapped to a robot face; head_sway refused (unknown field)"


def test_the_face_stream_chip_says_why_no_faces_arrive() -> None:
    quiet = {**GOOD, "input_fps": 0.0}
    assert evaluate(quiet, age=0.5)["input"].value == "0.0 fps"
    no_face = evaluate({**quiet, "ingest": {"no_face": True, "problem": None}}, age=0.5)
    assert (no_face["input"].ok, no_face["input"].value) == (False, "phone sees no face")
    refused = {**quiet, "ingest": {"no_face": False, "problem": "switch the app to ARKit"}}
    assert evaluate(refused, age=0.5)["input"].value == "switch the app to ARKit"
    # Faces arriving: the rate, whatever else happened a moment ago.
    assert evaluate({**GOOD, "ingest": {"no_face": True}}, age=0.5)["input"].value == "59.8 fps"


def test_a_recording_problem_is_a_red_chip_at_once_with_the_workers_sentence() -> None:
    sentence = "The disk is full where recordings are written (/data/rec): recording stopped."
    recording = {"active": True, "frames": {"participant": 40}, "problem": sentence}
    snapshot = HealthTracker().snapshot("b1", {**GOOD, "recording": recording}, 0.2, now=5.0)
    chip = _check(snapshot, "recording")
    assert (chip["ok"], chip["level"], chip["label"]) == (False, "alarm", "Recording")
    assert chip["value"] == sentence
    fine = evaluate({**GOOD, "recording": {"active": True, "frames": {"participant": 40}}}, 0.2)
    assert (fine["recording"].ok, fine["recording"].value) == (True, "recording, 40 frames")
    assert evaluate({**GOOD, "recording": {"active": False}}, 0.2)["recording"].value == "idle"
    assert "recording" not in evaluate(GOOD, 0.2)  # a worker without a recorder: no chip


def test_the_speaking_flags_age_adds_the_renderers_statistics_to_the_heartbeats() -> None:
    """The flag was sampled by the renderer (its statistics, once a second) before the
    heartbeat repeated it: the console compares speech events against that moment."""
    telemetry = {**GOOD, "stages": {"renderer": 0.8, "behaviour": 0.1}}
    snapshot = HealthTracker().snapshot("booth-1", telemetry, 0.6, now=10.0)
    assert snapshot["speaking_age_s"] == pytest.approx(1.4)
    assert HealthTracker().snapshot("booth-1", None, None, now=10.0)["speaking_age_s"] is None


def test_typed_speech_is_amber_while_espeak_is_missing_never_an_alarm() -> None:
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=3.0))
    missing = (False, "espeak-ng not installed (Debian/Ubuntu: apt install espeak-ng)")
    first = tracker.snapshot("booth-1", GOOD, 0.5, now=10.0, synthesiser=missing)
    later = tracker.snapshot("booth-1", GOOD, 0.5, now=100.0, synthesiser=missing)
    for snapshot in (first, later):
        check = next(c for c in snapshot["checks"] if c["id"] == "typed_speech")
        assert check["label"] == "Typed speech"
        assert check["level"] == "degraded"
        assert "apt install espeak-ng" in check["value"]
        assert "the Say field cannot speak" in check["value"]
        assert snapshot["alarm"] is False
    # Shown whatever the worker does: the server's own capability.
    silent = tracker.snapshot("booth-1", None, None, now=10.0, synthesiser=missing)
    assert any(c["id"] == "typed_speech" for c in silent["checks"])


def test_typed_speech_is_ok_with_espeak_or_a_robot_that_speaks_text_itself() -> None:
    found = evaluate(GOOD, 0.5, synthesiser=(True, "espeak-ng 1.51"))["typed_speech"]
    assert (found.ok, found.value) == (True, "espeak-ng 1.51")
    furhat = {**GOOD, "driver": "furhat"}
    own = evaluate(furhat, 0.5, synthesiser=(False, "espeak-ng not installed"))["typed_speech"]
    assert (own.ok, own.value) == (True, "the robot's own voice")
    assert "typed_speech" not in evaluate(GOOD, 0.5)  # not checked: no chip


# A booth with both robots (virtual+furhat): the heartbeat names the robot driven now and
# each robot's state; the study's conditions need the display (copy_2d) and the Furhat.
NEEDS = {"display": ["copy_2d"], "furhat": ["copy_furhat"]}
OPEN, CLOSED = (True, "display open"), (False, "no robot display open")


def two_robots(
    active: str, furhat: str = "connected", **furhat_detail: object
) -> dict[str, object]:
    outputs = {
        "display": {"state": "connected", "problem": None, "retry_in": None},
        "furhat": {"state": furhat, "problem": None, "retry_in": None, **furhat_detail},
    }
    return {**GOOD, "driver": "virtual+furhat", "robot_active": active,
            "robot_connected": (furhat if active == "furhat" else "connected") == "connected",
            "robot_outputs": outputs}  # fmt: skip


def test_two_robots_the_robot_chip_is_the_driven_one_and_says_which() -> None:
    on_display = evaluate(two_robots("display"), 0.5, display=CLOSED)["robot"]
    assert (on_display.ok, on_display.value) == (False, "no robot display open (the display "
                                                 "runs now)")  # fmt: skip
    on_furhat = evaluate(two_robots("furhat"), 0.5, display=CLOSED)["robot"]
    assert (on_furhat.ok, on_furhat.value) == (True, "connected (the Furhat runs now)")


def test_two_robots_the_one_a_later_condition_needs_says_when_it_is_missing() -> None:
    refused = two_robots("display", "auth_refused", problem="wrong key")
    checks = evaluate(refused, 0.5, display=OPEN, needs=NEEDS)
    assert "display" not in checks  # the Robot chip is the display's
    assert (checks["furhat"].ok, checks["furhat"].value) == (
        False, "login refused: wrong key; copy_furhat needs it")  # fmt: skip
    closed = evaluate(two_robots("furhat"), 0.5, display=CLOSED, needs=NEEDS)
    assert (closed["display"].ok, closed["display"].value) == (
        False, "no robot display open; copy_2d needs it")  # fmt: skip
    both = {"display": ["copy_2d", "copy_3d"]}
    fine = evaluate(two_robots("furhat"), 0.5, display=OPEN, needs=both)
    assert (fine["display"].ok, fine["display"].value) == (True, "display open (for copy_2d, "
                                                           "copy_3d)")  # fmt: skip
    assert "furhat" not in fine  # the Furhat is the Robot chip
    # Without the study's needs (not known) no such chip; a study without Furhat
    # conditions has none for the Furhat either.
    assert "furhat" not in evaluate(refused, 0.5, display=OPEN)
    assert "furhat" not in evaluate(refused, 0.5, display=OPEN, needs={"display": ["a"]})


def test_the_robot_a_later_condition_needs_stays_amber_never_an_alarm() -> None:
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=3.0))
    gone = two_robots("display", "disconnected", retry_in=2.0)
    tracker.snapshot("b1", gone, 0.2, now=0.0, display=OPEN, needs=NEEDS)
    later = tracker.snapshot("b1", gone, 0.2, now=60.0, display=OPEN, needs=NEEDS)
    furhat = _check(later, "furhat")
    assert (furhat["label"], furhat["level"], furhat["failing_for"]) == ("Furhat", "degraded",
                                                                          60.0)  # fmt: skip
    assert furhat["value"] == "disconnected; retrying in 2 s; copy_furhat needs it"
    assert later["alarm"] is False
    order = [c["id"] for c in later["checks"]]
    assert order.index("furhat") == order.index("robot") + 1


def test_a_booth_without_a_furhat_says_its_furhat_conditions_cannot_run() -> None:
    checks = evaluate({**GOOD, "driver": "virtual"}, 0.5, display=OPEN, needs=NEEDS)
    assert (checks["furhat"].ok, checks["furhat"].value) == (
        False, "this booth drives no Furhat (its worker's driver is virtual): copy_furhat "
        "cannot run")  # fmt: skip
    assert checks["robot"].value == "display open"
    assert "furhat" not in evaluate({**GOOD, "driver": "furhat"}, 0.5, needs=NEEDS)


def test_two_robots_typed_speech_follows_the_robot_driven_now() -> None:
    """The display has no text-to-speech (it skips typed text): while it runs, the Say
    field is not voiced, amber, never an alarm; while the Furhat runs, its own voice."""
    espeak = (True, "espeak-ng 1.51")  # the server's synthesiser is not used at this booth
    on_display = evaluate(two_robots("display"), 0.5, display=OPEN, synthesiser=espeak)
    check = on_display["typed_speech"]
    assert (check.ok, check.value) == (False, "not voiced while the display runs (it has no "
                                       "text-to-speech); the Furhat speaks typed text in its "
                                       "conditions")  # fmt: skip
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=3.0))
    tracker.snapshot("b1", two_robots("display"), 0.2, now=0.0, display=OPEN)
    later = tracker.snapshot("b1", two_robots("display"), 0.2, now=60.0, display=OPEN)
    assert _check(later, "typed_speech")["level"] == "degraded"
    assert later["alarm"] is False
    on_furhat = evaluate(two_robots("furhat"), 0.5, display=OPEN, synthesiser=espeak)
    assert (on_furhat["typed_speech"].ok, on_furhat["typed_speech"].value) == (
        True, "the Furhat's own voice")  # fmt: skip


def test_the_participant_video_chip_stays_amber_never_an_alarm() -> None:
    """A check from elsewhere than the worker (the participant video's) is graded too."""
    tracker = HealthTracker(limits=Thresholds(alarm_after_s=3.0))
    silent = {"video": Check("video", False, "video consented but ...", since_s=12.34)}
    tracker.snapshot("b1", GOOD, 0.2, now=0.0, extra=silent)
    later = tracker.snapshot("b1", GOOD, 0.2, now=60.0, extra=silent)
    video = _check(later, "video")
    assert (video["label"], video["level"], video["failing_for"], video["since_s"]) == (
        "Participant video", "degraded", 60.0, 12.3)  # fmt: skip
    assert later["alarm"] is False
    order = [c["id"] for c in later["checks"]]
    assert order.index("video") == order.index("speaking") - 1
