"""``chameleons worker --camera``: the worker tracks a local camera itself. A v4l2 loopback
device cannot be made here (no kernel module in the sandbox), so a video file stands in
for the camera (read at its own frame rate, as a camera delivers frames): real face
photos with a known roll, through the real tracker, mapping, transform, recording and
heartbeat of a running worker."""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import pytest
import zmq

from chameleons.worker.frames import BLENDSHAPE_INDEX
from chameleons.worker.recording import read_recording_table, recorded_sources
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.support.faces import Motion, scene
from tests.support.videos import write_video
from tests.worker.control_peer import ControlPeer

BOOTH = "booth-cam"


@pytest.fixture
def peer(server: ControlPeer) -> ControlPeer:
    """The server's end of the worker's control link (tests/worker/conftest.py)."""
    return server


def camera_video(path: Path, seconds: float = 4.0, rate: int = 15) -> Path:
    """The face rolled 15 degrees, the first second without a face, then in the dark."""
    n = round(seconds * rate)
    frames = [scene("astronaut", Motion(angle=15, face=k >= rate)) for k in range(n)]
    frames += [(scene("astronaut", Motion(angle=15)) // 10).astype(np.uint8)] * (2 * rate)
    return write_video(path, frames, rate)


def heartbeat(peer: ControlPeer, wanted: Callable[[dict[str, Any]], bool]) -> dict[str, Any]:
    """The first heartbeat whose ingest section satisfies ``wanted``."""

    def found() -> dict[str, Any] | None:
        for message in reversed(peer.of_type("heartbeat")):
            ingest: dict[str, Any] = message.body.get("ingest") or {}
            if wanted(ingest):
                return ingest
        return None

    result: dict[str, Any] = peer.wait(found, timeout=30)
    return result


def test_the_worker_tracks_a_camera_and_records_its_frames(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer, tmp_path: Path
) -> None:
    video = camera_video(tmp_path / "camera.mp4")
    config = WorkerConfig(booth=BOOTH, driver="null", command_endpoint=peer.command_endpoint,
                          telemetry_endpoint=peer.telemetry_endpoint, livelink_port=None,
                          facecapturex_port=None, camera=str(video), mirror=False)  # fmt: skip
    with Worker(config, context=zmq_context):
        ack = peer.command(BOOTH, "start_recording",
                           {"interaction_id": 3, "directory": str(tmp_path)})  # fmt: skip
        assert ack.ok, ack
        seeing = heartbeat(peer, lambda i: (i.get("receivers", {}).get("webcam", {})
                                            .get("frames", 0) >= 10))  # fmt: skip
        assert seeing["source"] == "webcam"
        assert seeing["receivers"]["webcam"]["no_face"] >= 5  # the face-less first second
        dark = heartbeat(peer, lambda i: "too dark" in str(i.get("problem")))
        assert "light the face" in dark["problem"]
        files = peer.command(BOOTH, "stop_recording", {"interaction_id": 3}).result["files"]
    table = read_recording_table(files["participant"])
    sources = recorded_sources(files["participant"])
    assert set(sources) == {("webcam-python", "geometric")}
    roll = np.array(table.column("head_roll").to_numpy())
    assert len(roll) >= 10
    base_roll = -2.7  # the photo's own roll upright (tests/facemesh: measured, +-1)
    assert float(np.median(roll)) == pytest.approx(15 + base_roll, abs=4)
    cheek = table.column("cheekPuff").to_numpy()
    assert np.isnan(cheek).all()  # missing, not zero
    assert np.isfinite(table.column("jawOpen").to_numpy()).all()
    assert BLENDSHAPE_INDEX["cheekPuff"] >= 0


def test_a_camera_that_cannot_be_opened_says_so(
    zmq_context: zmq.Context[zmq.Socket[bytes]], peer: ControlPeer, tmp_path: Path
) -> None:
    missing = str(tmp_path / "no-such-camera")
    config = WorkerConfig(booth=BOOTH, driver="null", command_endpoint=peer.command_endpoint,
                          telemetry_endpoint=peer.telemetry_endpoint, livelink_port=None,
                          facecapturex_port=None, camera=missing)  # fmt: skip
    with Worker(config, context=zmq_context):
        busy = heartbeat(peer, lambda i: "camera busy or missing" in str(i.get("problem")))
    assert "no-such-camera" in busy["problem"]
