"""The worker's capture-to-send latency is the pipeline's own: while the robot copies with a
delay, the delay is what the study asked for, not latency. Through a real worker (Live Link
over UDP, the copy behaviour, the renderer ticking, the heartbeat to a server peer), the
booth check's Face-stream step reads a few milliseconds, not "2000 ms to the robot" (it
warned "3993 ms" on every run with the study's 4 s)."""

from __future__ import annotations

import pytest
import zmq

from chameleons.backend.booth import check
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.worker.control_peer import ControlPeer
from tests.worker.head_stream import Pose, stream

DELAY = 2.0


@pytest.mark.slow
def test_the_copy_delay_is_not_counted_as_latency() -> None:
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    server = ControlPeer(context)
    config = WorkerConfig(booth="lat", driver="null", behaviour="copy", copy_delay=DELAY,
                          livelink_port=0, facecapturex_port=None, capture_host="127.0.0.1",
                          command_endpoint=server.command_endpoint,
                          telemetry_endpoint=server.telemetry_endpoint)  # fmt: skip
    worker = Worker(config, context=context).start()
    try:
        sent = stream(worker.receivers["livelink"].port, Pose(turn_at=0.5), DELAY + 1.5)
        copying = sent.start + DELAY + 1.0  # the robot has copied for a second by then

        def beat() -> dict[str, object] | None:
            beats = [m.body for m in server.of_type("heartbeat") if m.time > copying + 1.0]
            return beats[-1] if beats else None

        telemetry = server.wait(beat, timeout=10)
    finally:
        worker.stop()
        server.close()
        context.term()
    assert telemetry["behaviour"] == "copy"
    latency = telemetry["capture_to_send_ms"]
    assert isinstance(latency, float)
    assert 0.0 <= latency < check.MAX_LATENCY_MS
    face = check.face_stream(telemetry)
    assert face["status"] == "pass", face
    assert face["value"].endswith(f"{latency:.0f} ms to the robot")
