"""The copied head is re-centred on the participant's neutral pose (the booth's
``head_recentre`` setting, default on): through a real worker (Live Link over UDP in the
app's exact format, the copy behaviour, the Furhat driver to its test peer, the control link
to a server peer), a phone 15 degrees below the face no longer makes the robot look 15
degrees down at rest, a nod still reaches the robot at its full size, the setting off
copies the pose as captured, and the neutral is reported (acks, heartbeat, an event the
server logs with the session) and stored with every recording."""

from __future__ import annotations

import threading
from collections.abc import Iterator
from pathlib import Path

import pytest

from chameleons.worker.control import RECENTRE_HEAD, SET_BEHAVIOUR, START_RECORDING, STOP_RECORDING
from chameleons.worker.recording import read_recording_table, recording_metadata
from tests.worker.copy_booth import CopyBooth, copy_booth
from tests.worker.head_stream import Pose, stream

pytestmark = pytest.mark.slow
BOOTH = "rc"
PHONE_BELOW = 15.0  # degrees of pitch at rest: the phone sits below the face
CALIBRATION_S = 1.0


@pytest.fixture(params=[True, False], ids=["recentre", "as-captured"])
def booth(request: pytest.FixtureRequest, tmp_path: Path) -> Iterator[CopyBooth]:
    with copy_booth(BOOTH, copy_delay=0.3, head_recentre=request.param,
                    head_calibration_s=CALIBRATION_S, data_dir=tmp_path) as running:  # fmt: skip
        yield running


def pitches(booth: CopyBooth, since: float) -> list[float]:
    return booth.heads(since, "pitch")


def test_a_phone_below_the_face_does_not_make_the_robot_look_down(booth: CopyBooth) -> None:
    recentre = booth.worker.config.head_recentre
    ack = booth.server.command(BOOTH, SET_BEHAVIOUR, {"name": "copy", "params": {"delay": 0.3}})
    assert ack.ok
    assert ack.result["head"]["recentre"] is recentre
    pose = Pose(rest_pitch=PHONE_BELOW, nod_at=3.0, nod_deg=15.0, nod_s=1.0)
    sent = stream(booth.port, pose, 4.5)
    booth.robot.wait_for(lambda p: bool(pitches(booth, sent.start + 4.5 + 0.3)), timeout=10)
    rest = pitches(booth, sent.start + CALIBRATION_S + 1.0)[:50]  # before the nod, after 1 s
    nod = max(pitches(booth, sent.start + 3.0))
    if recentre:  # the robot rests looking ahead and nods as far as the participant did
        assert max(abs(p) for p in rest) < 1.0, rest
        assert 13.0 <= nod <= 15.5
    else:  # as captured: the robot looks down by the phone's offset (what labs reported)
        assert min(rest) > PHONE_BELOW - 1.0
        assert nod > PHONE_BELOW + 13.0
    # The neutral is reported: in the heartbeat and as an event the server logs.
    events = booth.server.wait(lambda: booth.server.of_type("head_neutral"), timeout=5)
    neutral = events[-1].body["neutral"]
    assert neutral["pose"]["pitch"] == pytest.approx(PHONE_BELOW, abs=0.2)
    assert (neutral["how"], neutral["frozen"], events[-1].body["recentre"]) == (
        "mean_of_first_frames", True, recentre)  # fmt: skip
    assert neutral["seconds"] == pytest.approx(CALIBRATION_S, abs=0.1)
    beat = booth.server.wait(lambda: [m.body for m in booth.server.of_type("heartbeat")
                                      if (m.body.get("head") or {}).get("neutral", {})
                                      .get("frozen")], timeout=5)[-1]  # fmt: skip
    assert beat["head"] == {"recentre": recentre, "neutral": neutral}


def test_recentre_head_measures_afresh_or_takes_the_rest_just_held(booth: CopyBooth) -> None:
    """A new participant: measured afresh from the next frames; the booth check's "hold
    still": the mean of the last seconds, at once."""
    sender = threading.Thread(target=stream, args=(booth.port, Pose(rest_yaw=-20.0), 2.0))
    sender.start()
    sender.join()
    held = booth.server.command(BOOTH, RECENTRE_HEAD, {"seconds": 1.0})
    assert held.ok
    assert held.result["neutral"]["pose"]["yaw"] == pytest.approx(-20.0, abs=0.1)
    assert held.result["neutral"]["how"] == "mean_of_rest"
    afresh = booth.server.command(BOOTH, RECENTRE_HEAD, {})
    assert afresh.result["neutral"] == {"pose": None, "how": "calibrating", "frozen": False,
                                        "frames": 0, "seconds": 0.0,
                                        "calibration_s": CALIBRATION_S}  # fmt: skip
    refused = booth.server.command(BOOTH, RECENTRE_HEAD, {"seconds": 60.0})
    assert (refused.ok, refused.error) == (False, "bad_field")


def test_every_recording_says_how_the_head_was_processed(booth: CopyBooth, tmp_path: Path) -> None:
    body = {"interaction_id": 7, "directory": str(tmp_path)}
    started = booth.server.command(BOOTH, START_RECORDING, body)
    assert started.ok
    stream(booth.port, Pose(rest_pitch=PHONE_BELOW), 0.5)
    stopped = booth.server.command(BOOTH, STOP_RECORDING, {"interaction_id": 7})
    for path in stopped.result["files"].values():
        metadata = recording_metadata(read_recording_table(path))
        assert metadata["head_processing"] == {
            "rotation_scale": "radians", "mounting_rotation_deg": 0.0, "mirror": False,
            "recentre": booth.worker.config.head_recentre, "calibration_s": CALIBRATION_S,
        }  # fmt: skip
