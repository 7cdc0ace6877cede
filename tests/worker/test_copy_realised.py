"""What a jittered or intermittent copy actually drew, through a real worker: Live Link Face
over UDP in, the Furhat driver to its test peer out, the server's end of the control link
receiving the worker's ``copy_draw`` events. The reported delays are the seeded draws, in
order, and their mean and SD match the distribution's; the reported bouts are the seeded
schedule's, and the share of time copying matches ``bout_s / (bout_s + 1 / rate)``."""

from __future__ import annotations

from collections.abc import Iterator
from typing import Any

import numpy as np
import pytest

from chameleons.worker.behaviours.copy_timing import BoutSchedule, DelaySchedule
from chameleons.worker.control import SET_BEHAVIOUR
from chameleons.worker.envelope import Message
from tests.worker.copy_booth import CopyBooth, copy_booth
from tests.worker.head_stream import Pose, stream

pytestmark = pytest.mark.slow
BOOTH = "realised"


@pytest.fixture
def booth() -> Iterator[CopyBooth]:
    with copy_booth(BOOTH, head_recentre=False) as running:
        yield running


def draws_after(booth: CopyBooth, params: dict[str, Any], seconds: float, n: int
                ) -> list[Message]:  # fmt: skip
    """Set ``copy`` with ``params``, stream the participant's head for ``seconds``, and wait
    for at least ``n`` ``copy_draw`` events of that set-up (its seed)."""
    ack = booth.server.command(BOOTH, SET_BEHAVIOUR, {"name": "copy", "params": params})
    assert ack.ok, ack
    stream(booth.port, Pose(turn_at=0.5, turn_deg=20.0, turn_s=1.0), seconds)

    def found() -> list[Message]:
        mine = [m for m in booth.server.of_type("copy_draw") if m.body["seed"] == params["seed"]]
        return mine if len(mine) >= n else []

    events: list[Message] = booth.server.wait(found, timeout=15)
    assert all(m.topic == f"event.{BOOTH}" for m in events)
    assert booth.robot.of_type("request.face.headpose")  # the robot was driven meanwhile
    return events


def test_jittered_delays_are_reported_as_drawn(booth: CopyBooth) -> None:
    delay: dict[str, Any] = {"uniform": [0.4, 1.2]}
    params = {"delay": delay, "delay_resample_s": 0.5, "seed": 11}
    events = draws_after(booth, params, 12.0, 20)
    blocks = [m.body["block"] for m in events]
    assert blocks == list(range(len(blocks)))  # each block once, in order, none skipped
    schedule = DelaySchedule(delay, 11, 0.5, maximum=11.5)
    delays = np.array([m.body["delay_s"] for m in events])
    assert list(delays) == [schedule.draw(k) for k in blocks]  # the seeded draws
    assert [m.body["at_s"] for m in events] == [0.5 * k for k in blocks]
    assert delays.min() >= 0.4
    assert delays.max() <= 1.2
    # Uniform(0.4, 1.2): mean 0.8, SD 0.8 / sqrt(12) = 0.231; with >= 20 draws the mean's
    # standard error is <= 0.052 and the SD's about 0.04.
    assert delays.mean() == pytest.approx(0.8, abs=0.16)
    assert delays.std(ddof=1) == pytest.approx(0.8 / np.sqrt(12), abs=0.1)
    times = [m.body["worker_time"] for m in events]
    assert np.allclose(np.diff(times), 0.5)  # on the worker's clock, resample_s apart


def test_bouts_are_reported_with_their_rests_and_delays(booth: CopyBooth) -> None:
    delay: dict[str, Any] = {"normal": {"mean": 0.7, "sd": 0.1}}
    params = {"delay": delay, "seed": 5,
              "intermittent": {"rate_per_s": 2.0, "bout_s": 0.4}}  # fmt: skip
    events = draws_after(booth, params, 10.0, 12)
    bouts = BoutSchedule(2.0, 0.4, seed=5)
    delays = DelaySchedule(delay, 5, 10.0, maximum=11.5)
    numbers = [m.body["bout"] for m in events]
    assert numbers == list(range(len(numbers)))
    for m in events:
        i = m.body["bout"]
        assert m.body["at_s"] == bouts.onset(i)
        assert m.body["rest_s"] == pytest.approx(bouts.rest_before(i))
        assert m.body["bout_s"] == 0.4
        assert m.body["delay_s"] == delays.draw(i)  # one draw per bout
    copying = sum(m.body["bout_s"] for m in events)
    cycle = sum(m.body["bout_s"] + m.body["rest_s"] for m in events)
    # Expected 0.4 / (0.4 + 0.5) = 0.44; the rests are exponential (SD 0.5 s each), so
    # over >= 12 cycles the share is within about +-0.15.
    assert copying / cycle == pytest.approx(0.4 / 0.9, abs=0.15)


def test_a_fixed_delay_draws_nothing(booth: CopyBooth) -> None:
    draws_after(booth, {"delay": {"uniform": [0.5, 0.6]}, "delay_resample_s": 0.5, "seed": 3},
                2.0, 2)  # fmt: skip
    ack = booth.server.command(BOOTH, SET_BEHAVIOUR, {"name": "copy", "params": {"delay": 0.5}})
    assert ack.ok, ack
    switch_at = ack.result["switch_at"]
    sent = stream(booth.port, Pose(), 2.0)
    booth.robot.wait_for(lambda p: bool(booth.heads(sent.start + 2.0, "yaw")), timeout=10)
    booth.heartbeat(lambda b: b.get("behaviour_params") == {"delay": 0.5})
    draws = booth.server.of_type("copy_draw")
    assert draws  # the jittered set-up's, before the switch
    # Nothing drawn from the switch on: the fixed delay draws nothing, and the jittered
    # set-up being faded out reports nothing more. (The head is sampled head_lead later
    # than the face, the renderer's filter delay: a draw that shows in the head first.)
    lead = booth.worker.config.head_lead
    assert max(m.body["worker_time"] for m in draws) < switch_at + lead
    assert {m.body["seed"] for m in draws} == {3}
