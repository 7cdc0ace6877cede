"""Speech through the Furhat as the real robot behaves: it queues a second audio behind the
first unless told to stop/abort, and answers each request with its own ``request_id``
(the peer models both, after Furhat's own client ``furhat-realtime-api`` 0.1.3)."""

from __future__ import annotations

import queue
import time

import pytest

from chameleons.worker.drivers import SPEECH_END, SPEECH_START, DriverEvent, FurhatDriver
from tests.worker.furhat_peer import FurhatPeer

Speech = tuple[str, str, str | None]  # (start/end, prompt, outcome)


def _connected(url: str) -> tuple[FurhatDriver, queue.SimpleQueue[DriverEvent]]:
    events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
    driver = FurhatDriver(url, backoff_initial=0.05)
    driver.bind_events(events.put)
    driver.start()
    deadline = time.monotonic() + 10
    while not driver.connected:
        events.get(timeout=max(0.01, deadline - time.monotonic()))
    return driver, events


def _speech_until(events: queue.SimpleQueue[DriverEvent], last: str) -> list[Speech]:
    """Speech events until ``last`` ends (generous deadline: a busy machine is slow)."""
    seen: list[Speech] = []
    deadline = time.monotonic() + 15
    while time.monotonic() < deadline:
        event = events.get(timeout=15)
        if event.kind not in (SPEECH_START, SPEECH_END):
            continue
        kind = "start" if event.kind == SPEECH_START else "end"
        seen.append((kind, event.body["prompt_id"], event.body.get("outcome")))
        if kind == "end" and event.body["prompt_id"] == last:
            return seen
    raise AssertionError(f"{last} never ended; saw {seen}")


def _wait_started(events: queue.SimpleQueue[DriverEvent], prompt: str) -> None:
    deadline = time.monotonic() + 10
    while time.monotonic() < deadline:
        event = events.get(timeout=10)
        if event.kind == SPEECH_START and event.body["prompt_id"] == prompt:
            return
    raise AssertionError(f"{prompt} never started")


@pytest.mark.parametrize("echo", [True, False], ids=["request_id", "no_request_id"])
def test_a_prompt_during_a_prompt_stops_the_first_and_gets_only_its_own_events(
    echo: bool,
) -> None:
    with FurhatPeer(speech_seconds=0.6, echo_request_id=echo) as peer:
        driver, events = _connected(peer.url)
        try:
            driver.play_audio("p1", "http://s/p1.wav")
            _wait_started(events, "p1")
            driver.play_audio("p2", "http://s/p2.wav")
            seen = _speech_until(events, "p2")
            kinds = [r.type for r in peer.received if r.type.startswith("request.speak")]
            second = peer.of_type("request.speak.audio")[1].message
        finally:
            driver.close()
    # p1 ends once, interrupted, when p2 replaces it (the renderer may not have heard of it
    # speaking yet); the robot's own end of p1 (aborted) is not taken for p2's: p2 starts,
    # then ends, played.
    assert seen == [("end", "p1", "interrupted"), ("start", "p2", None), ("end", "p2", "played")]
    assert kinds == ["request.speak.audio", "request.speak.stop", "request.speak.audio"]
    assert second["abort"] is True
    assert driver.speech.replaced[-1].outcome == "interrupted"


def test_a_prompt_before_the_previous_one_started_skips_it_on_the_robot_too() -> None:
    with FurhatPeer(speech_seconds=0.3, start_latency=0.4) as peer:
        driver, events = _connected(peer.url)
        try:
            driver.play_audio("p1", "http://s/p1.wav")
            driver.play_audio("p2", "http://s/p2.wav")
            seen = _speech_until(events, "p2")
            spoken = list(peer.spoken)
        finally:
            driver.close()
    assert seen == [("end", "p1", "skipped"), ("start", "p2", None), ("end", "p2", "played")]
    assert spoken == ["http://s/p2.wav"]  # the robot never played p1's audio first


def test_rapid_presses_are_skipped_never_played() -> None:
    with FurhatPeer(speech_seconds=0.2, start_latency=0.2) as peer:
        driver, events = _connected(peer.url)
        try:
            for n in range(5):
                driver.play_audio(f"p{n}", f"http://s/p{n}.wav")
            seen = _speech_until(events, "p4")
            spoken = list(peer.spoken)
        finally:
            driver.close()
    assert [s for s in seen if s[1] != "p4"] == [("end", f"p{n}", "skipped") for n in range(4)]
    assert [s for s in seen if s[1] == "p4"] == [("start", "p4", None), ("end", "p4", "played")]
    assert spoken == ["http://s/p4.wav"]


def _stop_while_speaking(driver: FurhatDriver, events: queue.SimpleQueue[DriverEvent]) -> None:
    """Prompt p1 starts on the robot, then the wizard stops it."""
    driver.play_audio("p1", "http://s/p1.wav")
    _wait_started(events, "p1")
    driver.stop_audio()


def test_a_stopped_prompt_ends_as_stopped_not_played() -> None:
    with FurhatPeer(speech_seconds=5.0) as peer:
        driver, events = _connected(peer.url)
        try:
            _stop_while_speaking(driver, events)
            seen = _speech_until(events, "p1")
        finally:
            driver.close()
    assert seen == [("end", "p1", "stopped")]


@pytest.mark.parametrize("end_back", [True, False], ids=["end_back", "at_once"])
def test_a_prompt_right_after_a_stop_aborts_and_sends_no_second_stop(end_back: bool) -> None:
    """The render stage stops a prompt under way before the next one; whether the robot's
    end of it has come back by then is a race on a busy machine: the requests are the same."""
    with FurhatPeer(speech_seconds=5.0) as peer:
        driver, events = _connected(peer.url)
        try:
            _stop_while_speaking(driver, events)
            if end_back:
                assert _speech_until(events, "p1") == [("end", "p1", "stopped")]
            peer.speech_seconds = 0.2
            driver.play_audio("p2", "http://s/p2.wav")
            seen = _speech_until(events, "p2")
            kinds = [r.type for r in peer.received if r.type.startswith("request.speak")]
            second = peer.of_type("request.speak.audio")[1].message
        finally:
            driver.close()
    assert kinds == ["request.speak.audio", "request.speak.stop", "request.speak.audio"]
    assert second["abort"] is True
    assert [s for s in seen if s[1] == "p2"] == [("start", "p2", None), ("end", "p2", "played")]


def test_start_latency_is_reported_as_the_robot_gives_it() -> None:
    with FurhatPeer(speech_seconds=0.1, start_latency=0.5) as peer:
        driver, events = _connected(peer.url)
        try:
            sent = time.monotonic()
            driver.play_audio("p1", "http://s/p1.wav")
            _wait_started(events, "p1")
            waited = time.monotonic() - sent
        finally:
            driver.close()
    assert waited >= 0.5  # the start is the robot's, not the request's
