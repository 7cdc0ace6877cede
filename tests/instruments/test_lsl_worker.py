"""``chameleons worker --lsl``: a real worker (Live Link over UDP, the copy behaviour, the
renderer ticking) publishes the participant's face and the robot's rendered face as LSL
``Face`` streams that real inlets on this machine resolve and read."""

from __future__ import annotations

import uuid

import numpy as np
import pylsl
import pytest
import zmq

from chameleons.instruments.lsl import FACE_LABELS
from chameleons.worker.frames import N_BLENDSHAPES
from chameleons.worker.runtime import Worker, WorkerConfig
from tests.instruments.lsl_inlets import labels, open_inlet, pull_until, resolve
from tests.worker.control_peer import ControlPeer
from tests.worker.head_stream import Pose, stream

YAW = N_BLENDSHAPES  # the head's yaw: the first channel after the blendshapes


@pytest.mark.slow
def test_the_worker_publishes_both_faces_as_labelled_lsl_streams() -> None:
    booth = f"lsl-{uuid.uuid4().hex[:6]}"
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    server = ControlPeer(context)
    config = WorkerConfig(booth=booth, driver="null", behaviour="copy", copy_delay=0.0,
                          livelink_port=0, facecapturex_port=None, capture_host="127.0.0.1",
                          command_endpoint=server.command_endpoint,
                          telemetry_endpoint=server.telemetry_endpoint, lsl=True)  # fmt: skip
    worker = Worker(config, context=context).start()
    try:
        participant = open_inlet(resolve(f"chameleons-{booth}-participant"))
        robot = open_inlet(resolve(f"chameleons-{booth}-robot"))
        before = pylsl.local_clock()
        sent = stream(worker.receivers["livelink"].port, Pose(turn_at=0.3), 2.0)
        after = pylsl.local_clock()
        faces, face_times = pull_until(participant, sent.count)
        rendered, render_times = pull_until(robot, 200)
        infos = participant.info(), robot.info()
        names = labels(participant), labels(robot)
    finally:
        worker.stop()
        server.close()
        context.term()
    for info in infos:
        assert info.type() == "Face"
        assert info.channel_count() == 61
        assert info.channel_format() == pylsl.cf_float32
    assert infos[1].nominal_srate() == config.render.tick_rate
    assert names[0] == names[1] == list(FACE_LABELS)
    assert names[0][0] == "EyeBlinkLeft"
    assert names[0][YAW] == "HeadYaw"
    # Every captured frame, stamped with its capture time on LSL's clock.
    assert len(faces) >= sent.count * 0.9
    assert before - 0.5 <= face_times[0] <= face_times[-1] <= after + 0.5
    assert np.all(np.diff(face_times) >= 0)
    yaw = np.abs(np.array(faces)[:, YAW])
    assert yaw.max() > 20  # the 30-degree turn, in degrees
    # The robot copied it (no delay), each tick stamped when it was due.
    robot_yaw = np.abs(np.array(rendered)[:, YAW])
    assert robot_yaw.max() > 10
    spacing = np.median(np.diff(render_times))
    assert spacing == pytest.approx(1 / config.render.tick_rate, rel=0.2)
    assert before - 1.0 <= render_times[0]
    assert render_times[-1] <= pylsl.local_clock() + 1.0
