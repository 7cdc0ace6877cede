"""Copy's channels through a real worker: Live Link Face over UDP in, the Furhat driver to
its test peer out, set up by a server peer over the control link. Head-only copies the
participant's head turn; face-only leaves the robot's head at rest; a gain halves it."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import pytest

from chameleons.worker.control import SET_BEHAVIOUR
from tests.worker.copy_booth import CopyBooth, copy_booth
from tests.worker.head_stream import Pose, stream

pytestmark = pytest.mark.slow
BOOTH = "channels"
DELAY = 0.3
TURN = 30.0


@pytest.fixture
def booth() -> Iterator[CopyBooth]:
    with copy_booth(BOOTH, copy_delay=DELAY, head_recentre=False) as running:
        yield running


def largest_turn(booth: CopyBooth, params: dict[str, Any]) -> float:
    """The robot's largest head yaw while the participant turns 30 deg and back."""
    ack = booth.server.command(BOOTH, SET_BEHAVIOUR, {"name": "copy", "params": params})
    assert ack.ok, ack
    sent = stream(booth.port, Pose(turn_at=0.5, turn_deg=TURN, turn_s=1.0), 2.0)
    end = sent.start + 2.0 + DELAY
    booth.robot.wait_for(lambda p: bool(booth.heads(end, "yaw")), timeout=10)
    return max(abs(y) for y in booth.heads(sent.start + 0.5, "yaw"))


def test_head_only_face_only_and_gain_reach_the_robot(booth: CopyBooth) -> None:
    assert largest_turn(booth, {"delay": DELAY, "channels": "head"}) == pytest.approx(TURN, abs=1.5)
    assert largest_turn(booth, {"delay": DELAY, "channels": "face"}) < 0.5
    halved = largest_turn(booth, {"delay": DELAY, "channels": "head", "gain": 0.5})
    assert halved == pytest.approx(TURN / 2, abs=1.0)
