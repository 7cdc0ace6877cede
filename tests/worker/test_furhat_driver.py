"""The Furhat driver against a real WebSocket peer speaking the Realtime API subset."""

from __future__ import annotations

import logging
import queue

import numpy as np
import pytest

from chameleons.worker.drivers import (
    SPEECH_END,
    SPEECH_START,
    DriverEvent,
    DriverOptions,
    FurhatDriver,
    create_driver,
)
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES
from tests.worker.furhat_peer import FurhatPeer


@pytest.fixture
def peer():
    with FurhatPeer() as running:
        yield running


def _driver(url: str) -> tuple[FurhatDriver, queue.SimpleQueue[DriverEvent]]:
    events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
    driver = FurhatDriver(url, key="secret", face_id="adult-01", backoff_initial=0.05)
    driver.bind_events(events.put)
    return driver, events


def _wait_connected(driver: FurhatDriver, events: queue.SimpleQueue[DriverEvent]) -> None:
    while not driver.connected:
        events.get(timeout=5)


def test_handshake_configures_the_face_with_idle_behaviour_off(peer: FurhatPeer) -> None:
    driver, events = _driver(peer.url)
    driver.start()
    try:
        _wait_connected(driver, events)
        peer.wait_for(lambda p: bool(p.of_type("request.face.config")))
        first, config = peer.received[0].message, peer.of_type("request.face.config")[0].message
        assert first == {"type": "request.auth", "key": "secret"}
        # Only the fields Furhat's own client sends; the face is never mixed with others.
        assert config == {"type": "request.face.config", "face_id": "adult-01",
                          "visibility": True, "microexpressions": False}  # fmt: skip
        peer.wait_for(lambda p: len(p.of_type("request.face.config")) >= 3)
        separate = [r.message for r in peer.of_type("request.face.config")[1:]]
        assert [sorted(set(m) - {"type", "request_id"}) for m in separate] == [
            ["blinking"], ["head_sway"],
        ]  # fmt: skip
        assert all(m[next(iter(set(m) - {"type", "request_id"}))] is False for m in separate)
    finally:
        driver.close()


def test_face_params_use_upper_snake_names_and_head_pose_degrees(peer: FurhatPeer) -> None:
    driver, events = _driver(peer.url)
    driver.start()
    try:
        _wait_connected(driver, events)
        shapes = np.zeros(N_BLENDSHAPES, dtype=np.float32)
        shapes[BLENDSHAPE_INDEX["eyeBlinkLeft"]] = 0.25
        shapes[BLENDSHAPE_INDEX["jawOpen"]] = 0.5
        driver.send_face(shapes)
        driver.send_head(12.5, -3.0, 1.25)
        peer.wait_for(lambda p: bool(p.of_type("request.face.params"))
                      and bool(p.of_type("request.face.headpose")))  # fmt: skip
        params = peer.of_type("request.face.params")[0].message["params"]
        head = peer.of_type("request.face.headpose")[0].message
    finally:
        driver.close()
    assert params["EYE_BLINK_LEFT"] == 0.25
    assert params["JAW_OPEN"] == 0.5
    assert "TONGUE_OUT" not in params
    assert len(params) == N_BLENDSHAPES - 1
    assert head == {"type": "request.face.headpose", "yaw": 12.5, "pitch": -3.0, "roll": 1.25,
                    "relative": False}  # fmt: skip


def test_speak_audio_by_url_with_lipsync_off_reports_start_and_end(peer: FurhatPeer) -> None:
    driver, events = _driver(peer.url)
    driver.start()
    try:
        _wait_connected(driver, events)
        driver.play_audio("p1", "http://server/prompts/p1.wav")
        kinds = []
        while SPEECH_END not in kinds:
            event = events.get(timeout=5)
            kinds.append(event.kind)
            if event.kind in (SPEECH_START, SPEECH_END):
                assert event.body["prompt_id"] == "p1"
        driver.stop_audio()
        peer.wait_for(lambda p: bool(p.of_type("request.speak.stop")))
    finally:
        driver.close()
    speak = peer.of_type("request.speak.audio")[0].message
    assert speak == {"type": "request.speak.audio", "url": "http://server/prompts/p1.wav",
                     "lipsync": False, "abort": False,
                     "request_id": speak["request_id"]}  # fmt: skip
    assert speak["request_id"]
    assert kinds.index(SPEECH_START) < kinds.index(SPEECH_END)


def test_reconnects_after_the_robot_drops_the_connection(peer: FurhatPeer) -> None:
    driver, events = _driver(peer.url)
    driver.start()
    try:
        _wait_connected(driver, events)
        peer.drop_connections()
        states = []
        while not (driver.connected and "disconnected" in states):
            event = events.get(timeout=5)
            states.append(event.body.get("state"))
        peer.wait_for(lambda p: p.connections == 2 and len(p.of_type("request.auth")) == 2)
        driver.send_head(1.0, 2.0, 3.0)
        peer.wait_for(lambda p: bool(p.of_type("request.face.headpose")))
        assert driver.connects == 2
    finally:
        driver.close()


def test_sending_never_blocks_without_a_robot() -> None:
    driver, events = _driver("ws://127.0.0.1:9/v1/events")  # nothing listens there
    driver.start()
    try:
        for _ in range(1000):
            driver.send_head(0.0, 0.0, 0.0)
        assert driver.dropped >= 1000 - 8  # bounded queue: the stale frames are dropped
        driver.play_audio("p", "http://x/a.wav")
        kinds = []
        while SPEECH_END not in kinds:
            kinds.append(events.get(timeout=5).kind)
        assert not driver.connected
    finally:
        driver.close()


def _face_configs(peer: FurhatPeer, count: int) -> list[object]:
    peer.wait_for(lambda p: len(p.of_type("request.face.config")) >= count)
    return [r.message.get("face_id") for r in peer.of_type("request.face.config")]


def test_study_face_ids_are_sent_as_the_mapped_robot_faces(peer: FurhatPeer) -> None:
    events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
    driver = FurhatDriver(peer.url, face_id="face-1", faces={"face-1": "Isabel",
                                                             "face-2": "Marty"})  # fmt: skip
    driver.bind_events(events.put)
    driver.start()
    try:
        _wait_connected(driver, events)
        driver.set_face("face-2")
        assert _face_configs(peer, 4) == ["Isabel", None, None, "Marty"]
        stats = driver.stats()
    finally:
        driver.close()
    assert (stats["face_id"], stats["robot_face_id"], stats["unmapped_face"]) == (
        "face-2", "Marty", None,
    )  # fmt: skip


def test_an_unmapped_face_is_sent_unchanged_warned_once_and_reported(
    peer: FurhatPeer, caplog: pytest.LogCaptureFixture
) -> None:
    events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
    driver = FurhatDriver(peer.url, faces={"face-1": "Isabel"})
    driver.bind_events(events.put)
    driver.start()
    try:
        _wait_connected(driver, events)
        with caplog.at_level(logging.WARNING, logger="chameleons.worker.drivers.furhat"):
            driver.set_face("face-3")
            driver.set_face("face-3")
            sent = _face_configs(peer, 5)
        unmapped = driver.stats()["unmapped_face"]
        driver.set_face("face-1")
        assert _face_configs(peer, 6)[-1] == "Isabel"
        assert driver.stats()["unmapped_face"] is None
    finally:
        driver.close()
    assert sent == [None, None, None, "face-3", "face-3"]  # handshake: the robot's own face
    assert unmapped == "face-3"
    warnings = [r for r in caplog.records if "face-3" in r.getMessage()]
    assert len(warnings) == 1


def test_create_driver_passes_the_face_map_to_the_furhat_driver() -> None:
    options = DriverOptions(furhat_faces={"face-1": "Isabel"})
    driver = create_driver("furhat", options, lambda *_args: None)
    assert isinstance(driver, FurhatDriver)
    assert driver.faces == {"face-1": "Isabel"}
