"""The phone's timecode is checked before it is trusted: through a real worker (capture on
a UDP port, the copy behaviour, the Furhat driver to its test peer, the control link to a
server peer), a head turn streamed in the Live Link Face app's exact format with a frozen,
jumping or drifting timecode reaches the robot exactly the copy's delay later (the worker
falls back to arrival times), and the heartbeat says why, as the wizard's health strip
shows it. Datagrams reordered by 0-40 ms of network jitter are put back in order, none
dropped."""

from __future__ import annotations

import time
from collections.abc import Iterator

import pytest

from chameleons.backend.wizard import health
from tests.worker.copy_booth import CopyBooth, copy_booth
from tests.worker.head_stream import (
    Pose,
    Sent,
    Timecode,
    drifting_timecode,
    frozen_timecode,
    jumping_timecode,
    rising_edge,
    stream,
    true_timecode,
)

pytestmark = pytest.mark.slow
BOOTH = "tc"
DELAY = 0.5  # the copy's delay (short, so the tests are)
TOLERANCE = 0.1  # the robot's turn against the phone's, beyond the delay (s)


@pytest.fixture
def booth() -> Iterator[CopyBooth]:
    with copy_booth(BOOTH, copy_delay=DELAY, head_recentre=False) as running:
        yield running


def copied_after(booth: CopyBooth, pose: Pose, sent: Sent, *, on_arrival: bool = False) -> float:
    """Seconds from the phone's head passing half its turn to the robot's doing so. With a
    trusted timecode the copy keeps the capture times (the schedule); ``on_arrival`` (an
    untrusted timecode) it follows when the packets arrived, measured from when they left,
    since a busy machine's sender can leave late."""
    assert pose.turn_at is not None
    half = pose.turn_at + pose.turn_s / 6  # the half sine passes 0.5 at 1/6
    phone = sent.left_at(half) if on_arrival else sent.start + half
    booth.robot.wait_for(lambda p: any(r.time > phone + DELAY + 0.5 for r in p.received),
                         timeout=10)  # fmt: skip
    heads = booth.robot.of_type("request.face.headpose")
    robot = rising_edge([r.time for r in heads], [r.message["yaw"] for r in heads],
                        pose.turn_deg / 2)  # fmt: skip
    assert robot is not None, "the robot never turned"
    return robot - phone


@pytest.mark.parametrize(
    ("timecode", "turn_at", "problem"),
    [(true_timecode, 2.0, None), (frozen_timecode, 2.0, "frozen"),
     (jumping_timecode, 2.0, "keeps jumping"), (drifting_timecode, 4.0, "drifts")],
)  # fmt: skip
def test_a_bad_timecode_falls_back_to_arrival_time_and_the_copy_keeps_its_delay(
    booth: CopyBooth, timecode: Timecode, turn_at: float, problem: str | None
) -> None:
    pose = Pose(turn_at=turn_at, turn_deg=30.0)
    sent = stream(booth.port, pose, turn_at + 2.0, timecode=timecode)
    delay = copied_after(booth, pose, sent, on_arrival=problem is not None)
    assert DELAY - 0.02 <= delay <= DELAY + TOLERANCE, f"copied {delay:.3f} s later"
    beat = booth.heartbeat(lambda body: body["ingest"]["input_fps"] > 0)
    reported = beat["ingest"]["timecode_problem"]
    checks = health.evaluate(beat, 0.0)
    if problem is None:
        assert reported is None
        assert "timecode" not in checks
    else:
        assert reported is not None
        assert problem in reported
        # The wizard's health strip shows it: the copy now runs on arrival times.
        assert checks["timecode"].ok is False
        assert checks["timecode"].value == f"{reported}: copying on arrival times"
        assert beat["ingest"]["receivers"]["livelink"]["timecode"]["trusted"] is False


def test_datagrams_reordered_by_network_jitter_are_put_back_in_order(booth: CopyBooth) -> None:
    """0-40 ms of random delay per datagram: about a sixth arrive after a later one. All
    are put back in capture order within the 50 ms window; none is dropped."""
    pose = Pose(turn_at=2.0, turn_deg=30.0)
    sent = stream(booth.port, pose, 4.0, jitter_s=0.040)
    delay = copied_after(booth, pose, sent)
    assert DELAY - 0.02 <= delay <= DELAY + TOLERANCE
    time.sleep(0.2)  # the last frames leave the reorder window
    history = booth.worker.behaviour.router.context.history
    assert history.out_of_order == 0  # (17.5 % of the frames were, and were dropped)
    timecode = booth.worker.ingest_stats()["receivers"]["livelink"]["timecode"]
    assert timecode["reordered"] > sent.count // 20  # the network did reorder them
    # On a busy test machine the sender's own sleeps may add a few ms beyond the window.
    assert timecode["late"] <= sent.count // 100
    assert booth.worker.behaviour.router.frames_in >= sent.count - timecode["late"]
    assert timecode["trusted"] is True
