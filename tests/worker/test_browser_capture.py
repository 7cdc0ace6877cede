"""The capture page's frames as a worker capture source (``webcam-browser``): the server's
relay code (:class:`CaptureLink`) turns the page's binary frames into envelopes, a real
ZeroMQ control link carries them to a running worker, which maps them (pose, features,
ARKit), publishes and records them, counts faceless frames, reports the page's camera
problems and takes the neutral-face calibration as a command."""

from __future__ import annotations

import struct
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zmq

from chameleons.backend.booth.check import face_stream
from chameleons.backend.capture.relay import HEADER, CaptureLink, CaptureProtocolError
from chameleons.facemesh.pose import canonical_landmarks
from chameleons.worker.envelope import serialize
from chameleons.worker.ingest.rotation import rotation_matrix
from chameleons.worker.recording import read_recording_table, recorded_sources
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.test_webcam_worker import heartbeat

BOOTH = "booth-page"


@pytest.fixture
def peer(server: ControlPeer) -> ControlPeer:
    """The server's end of the worker's control link (tests/worker/conftest.py)."""
    return server


def page_frame(roll: float, captured_ms: float, sent_ms: float) -> bytes:
    """What the page sends for a face turned by ``roll`` degrees (478 points: irises too)."""
    points = canonical_landmarks(640, 480, rotation=rotation_matrix(0.0, 0.0, roll))
    irises = np.repeat(points[[33]], 10, axis=0)  # 468..477: the eye's corner will do
    points = np.vstack([points, irises]).astype("<f4")
    return HEADER.pack(captured_ms, sent_ms, 640, 480, len(points)) + points.tobytes()


def booth_check_face(peer: ControlPeer, wanted: str, status: dict[str, Any] | None = None
                     ) -> str:  # fmt: skip
    """The booth check's face step on the latest heartbeat with ``wanted`` in it; meanwhile
    the page goes on saying ``status`` (or, without one, that it sees no face) twice a
    second, as an open page does."""
    link, sent = CaptureLink(BOOTH), [0.0]

    def found() -> str | None:
        now = time.monotonic()
        if now - sent[0] > 0.5:
            ms = now * 1000
            relay(peer, link, link.status(status, now) if status is not None
                  else link.no_face_message({"captured": ms, "sent": ms + 5}, now))  # fmt: skip
            sent[0] = now
        for message in reversed(peer.of_type("heartbeat")):
            result = face_stream(message.body)
            if result["status"] == "fail" and wanted in result["value"]:
                return str(result["value"])
        return None

    value: str = peer.wait(found, timeout=30)
    return value


def relay(peer: ControlPeer, link: CaptureLink, message: Any) -> None:
    peer.send_raw(BOOTH, serialize(message))


def test_page_frames_are_mapped_published_and_recorded(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer, tmp_path: Path
) -> None:
    config = WorkerConfig(booth=BOOTH, driver="null", command_endpoint=peer.command_endpoint,
                          telemetry_endpoint=peer.telemetry_endpoint, livelink_port=None,
                          facecapturex_port=None, mirror=False)  # fmt: skip
    link = CaptureLink(BOOTH)
    with Worker(config, context=zmq_context) as worker:
        ack = peer.command(BOOTH, "start_recording",
                           {"interaction_id": 5, "directory": str(tmp_path)})  # fmt: skip
        assert ack.ok, ack
        relay(peer, link, link.status({"camera": "Fake camera", "brightness": 120}, 0.0))
        start = time.monotonic()
        for _k in range(12):  # 30 fps, each frame 40 ms from camera to the page's send
            now = time.monotonic()
            ms = (now - start) * 1000
            relay(peer, link, link.landmarks(page_frame(20.0, ms, ms + 40), now))
        for _k in range(3):
            now = time.monotonic()
            relay(peer, link, link.no_face_message({"captured": 1e3, "sent": 1e3 + 5}, now))
        seeing = heartbeat(peer, lambda i: i.get("receivers", {}).get("webcam-browser", {})
                           .get("frames", 0) >= 12)  # fmt: skip
        page = seeing["receivers"]["webcam-browser"]
        assert seeing["source"] == "webcam-browser"
        assert page["connected"]
        assert page["camera"] == "Fake camera"
        assert page["head"][2] == pytest.approx(20.0, abs=0.5)  # the roll, its sign
        assert heartbeat(peer, lambda i: i["receivers"]["webcam-browser"]["no_face"] >= 3)
        # The page stays open and sees nobody: the booth check's face step says so.
        assert booth_check_face(peer, "no face") == "camera sees no face"
        files = peer.command(BOOTH, "stop_recording", {"interaction_id": 5}).result["files"]
        assert worker.browser is not None
    table = read_recording_table(files["participant"])
    assert set(recorded_sources(files["participant"])) == {("webcam-browser", "geometric")}
    roll = table.column("head_roll").to_numpy()
    assert len(roll) == 12
    assert np.median(roll) == pytest.approx(20.0, abs=0.5)
    assert np.isnan(table.column("cheekPuff").to_numpy()).all()  # missing, not zero


def test_the_page_calibrates_the_neutral_face_and_reports_camera_problems(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer
) -> None:
    config = WorkerConfig(booth=BOOTH, driver="null", command_endpoint=peer.command_endpoint,
                          telemetry_endpoint=peer.telemetry_endpoint, livelink_port=None,
                          facecapturex_port=None)  # fmt: skip
    link = CaptureLink(BOOTH)
    with Worker(config, context=zmq_context) as worker:
        early = peer.command(BOOTH, "calibrate_webcam", {"action": "start"})
        assert early.ok
        assert early.result == {"collecting": True}
        too_few = peer.command(BOOTH, "calibrate_webcam", {"action": "finish"})
        assert too_few.result["calibrated"] is False
        assert "hold still" in too_few.result["problem"]
        assert peer.command(BOOTH, "calibrate_webcam", {"action": "start"}).ok
        for k in range(8):
            relay(peer, link, link.landmarks(page_frame(0.0, k * 33.0, k * 33.0 + 30),
                                             time.monotonic()))  # fmt: skip
        browser = worker.browser
        assert browser is not None
        peer.wait(lambda: browser.stats.frames >= 8, timeout=10)
        done = peer.command(BOOTH, "calibrate_webcam", {"action": "finish"})
        assert done.result == {"calibrated": True, "frames": 8, "calibration": "neutral"}
        busy = {"problem": "camera busy: another program is using it", "camera": ""}
        relay(peer, link, link.status(busy, time.monotonic()))
        seen = heartbeat(peer, lambda i: "camera busy" in str(i.get("problem")))
        assert seen["receivers"]["webcam-browser"]["calibration"] == "neutral"
        # Once the frames have stopped, the booth check's face step names the problem.
        assert "another program" in booth_check_face(peer, "camera busy", busy)
        dark = booth_check_face(peer, "too dark", {"brightness": 12, "camera": "Cam"})
        assert "brightness 12 of 255" in dark
        relay(peer, link, link.status(None, time.monotonic(), connected=False))
        assert heartbeat(peer, lambda i: not i["receivers"]["webcam-browser"]["connected"])


def test_the_relay_maps_page_times_onto_the_server_clock_and_refuses_bad_frames() -> None:
    link = CaptureLink(BOOTH)
    # The page's clock runs 1000 s behind; the quickest frame arrives 2 ms after it is sent.
    first = link.landmarks(page_frame(0.0, 0.0, 50.0), now=1000.052)
    second = link.landmarks(page_frame(0.0, 100.0, 130.0), now=1000.140)  # 10 ms on the way
    assert first.body["capture_time"] == pytest.approx(1000.002, abs=1e-6)
    # The network's jitter is taken out: the page's 100 ms on the quickest frame's offset
    # (which may creep by the clock-drift allowance, 1 ms/s).
    assert second.body["capture_time"] == pytest.approx(1000.102, abs=1e-4)
    assert second.body["sent"] == 1000.140
    assert (second.body["width"], second.body["height"]) == (640, 480)
    good = page_frame(0.0, 0.0, 1.0)
    for bad in (good[:-4], good[:HEADER.size], b"x" * 9000,
                struct.pack("<5d", 0, 1, 640, 480, 10) + bytes(120),
                struct.pack("<5d", float("nan"), 1, 640, 480, 468) + bytes(468 * 12),
                struct.pack("<5d", 0, 1, 0, 480, 468) + bytes(468 * 12)):  # fmt: skip
        with pytest.raises(CaptureProtocolError):
            link.landmarks(bad, now=1.0)
