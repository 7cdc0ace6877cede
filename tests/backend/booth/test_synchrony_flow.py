"""The booth flow computes an interaction's synchrony in the background once its recording
has stopped and its files are indexed (a real worker recording a fed face)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from fastapi import FastAPI
from fastapi.testclient import TestClient

from chameleons.backend.booth.flows import BoothFlow
from chameleons.backend.synchrony import repository
from chameleons.backend.synchrony.loading import CHANNELS, load_stream
from chameleons.backend.withdrawal.files import recording_file
from chameleons.experiment.stats.synchrony import FaceStream
from chameleons.experiment.stats.synchrony.ccf import windowed_ccf
from chameleons.experiment.stats.synchrony.streams import grid, resample
from chameleons.worker.runtime import Worker
from chameleons.worker.simulate import LiveLinkSender, SyntheticFace, run_simulation
from tests.backend.booth.conftest import (
    feed_face,
    finish_interaction,
    new_session,
    participant_frames_recorded,
    until,
    wait_for_event,
)
from tests.backend.booth.test_flow_with_worker import interaction_id
from tests.experiment.meaccf_reference import meaccf
from tests.support.bots import StaffApi


def agent_frames_recorded(worker: Worker) -> int:
    recorder = worker.recorder.recorders.get("agent")
    return recorder.frames_written if recorder is not None else 0


@pytest.mark.slow
def test_synchrony_is_computed_in_the_background_when_the_recording_stops(
    app: FastAPI, client: TestClient, pi: StaffApi, study_id: int, worker: Worker,
    flow: BoothFlow,
) -> None:  # fmt: skip
    wizard, phone = new_session(pi, study_id)
    wizard.switch_condition("copy", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "recording.started")

    def face() -> None:
        # Both streams hold frames before the interaction ends (the robot's copy starts
        # 4 s after the face): on a busy machine the interaction could otherwise end first,
        # and the answer is then, rightly, "no frames" instead of "too short".
        feed_face(worker)
        until(lambda: participant_frames_recorded(worker) > 0, what="participant frames")
        until(lambda: agent_frames_recorded(worker) > 0, what="robot frames")

    finish_interaction(wizard, phone, 1, face)
    wait_for_event(wizard, "recording.stopped")
    assert flow.synchrony is not None
    assert client.portal is not None
    client.portal.call(flow.settled)  # the indexing job queues the computation
    client.portal.call(flow.synchrony.settled)
    assert flow.synchrony.computed == 1
    assert flow.synchrony.failed == 0
    target = interaction_id(app, wizard)
    with app.state.sessionmaker() as db:
        row = repository.stored(db, [target])[target]
    # A face fed for two seconds: recorded and measured, too short for a window.
    assert row.reason == "too_short"
    assert "synchrony needs at least 37 s" in row.detail  # 1 s settling, 30 s, 6 s
    assert row.params["window_s"] == 30.0
    assert set(row.recordings)  # the indexed recordings it read


@pytest.mark.slow
def test_both_implementations_agree_on_a_real_workers_recording(
    app: FastAPI, client: TestClient, pi: StaffApi, study_id: int, worker: Worker,
    flow: BoothFlow,
) -> None:  # fmt: skip
    """The participant's and the robot's streams as a real worker recorded them (the robot
    replaying its natural clip, the simulated face over Live Link), resampled as the service
    does, through the vectorised MEAccf and the loop-by-loop transcription: the same to
    1e-9."""
    wizard, phone = new_session(pi, study_id)
    wizard.switch_condition("natural", 1)
    wizard.start()
    wizard.advance(1, "discussion")
    wait_for_event(wizard, "recording.started")

    def paced_face() -> None:  # a phone's pace: 3 s of frames at 60 Hz, in real time
        sender = LiveLinkSender("127.0.0.1", worker.receivers["livelink"].port, fps=60.0)
        run_simulation(sender, iter(SyntheticFace(2).samples(60.0, 3.0)))
        until(lambda: participant_frames_recorded(worker) >= 150, what="the face recorded")

    finish_interaction(wizard, phone, 1, paced_face)
    wait_for_event(wizard, "recording.stopped")
    assert client.portal is not None
    client.portal.call(flow.settled)
    target = interaction_id(app, wizard)
    with app.state.sessionmaker() as db:
        own = repository.recordings(db, [target])[target]
    data_dir = Path(app.state.settings.data_dir)
    streams = {
        stream: FaceStream.of(loaded.times, loaded.values, CHANNELS)
        for stream, loaded in ((s, load_stream([recording_file(data_dir, r.path) for r in rs]))
                               for s, rs in own.items())
    }  # fmt: skip
    participant, robot = streams["participant"], streams["agent"]
    times = grid(max(participant.start, robot.start), min(participant.end, robot.end), 25)
    p = resample(participant, times, 0.25)
    r = resample(robot, times, 0.25)
    compared = 0
    for name in ("head_yaw", "head_pitch", "jawOpen", "eyeBlinkLeft"):
        column = CHANNELS.index(name)
        fast = windowed_ccf(p[:, column], r[:, column], 10, 5, 5)[0]  # 0.4 s, 0.2 s, 0.2 s
        slow = meaccf(p[:, column], r[:, column], 25, 0.2, 0.4, 0.2)
        assert np.array_equal(np.isnan(fast), np.isnan(slow))
        # Fisher's z is ill-conditioned near r = 1 (it reached 8.25 once): relative there.
        np.testing.assert_allclose(fast, slow, rtol=1e-9, atol=1e-9)
        compared += int(np.isfinite(slow).sum())
    assert compared > 50  # real correlations were compared, not only missing ones
