"""The server's bridge against real workers over TCP: commands, telemetry, display frames,
connection tracking, state replay after a restart, and bounded subscriber queues."""

from __future__ import annotations

import asyncio
import time
from collections.abc import Awaitable, Callable
from dataclasses import replace

import pytest
import zmq

from chameleons.backend.bridge import (
    Bridge,
    WorkerTimeoutError,
    WorkerUnavailableError,
)
from chameleons.backend.bridge.subscriptions import Subscription
from chameleons.worker.control import make_hello
from chameleons.worker.envelope import Message, serialize
from chameleons.worker.runtime import Worker, WorkerConfig

ANY_PORT = "tcp://127.0.0.1:*"


def _config(bridge: Bridge, booth: str, **changes: object) -> WorkerConfig:
    config = WorkerConfig(booth=booth, driver="null", livelink_port=None,
                          facecapturex_port=None, command_endpoint=bridge.command_endpoint,
                          telemetry_endpoint=bridge.telemetry_endpoint)  # fmt: skip
    return replace(config, **changes)  # type: ignore[arg-type]


async def _until(condition: Callable[[], object], timeout: float = 10.0) -> None:
    deadline = time.monotonic() + timeout
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError("condition not met in time")
        await asyncio.sleep(0.02)


def _run(test: Callable[[Bridge], Awaitable[None]]) -> None:
    async def main() -> None:
        async with Bridge(ANY_PORT, ANY_PORT) as bridge:
            await test(bridge)

    asyncio.run(main())


def test_commands_acks_and_errors() -> None:
    async def test(bridge: Bridge) -> None:
        with Worker(_config(bridge, "b1")):
            await _until(lambda: "b1" in bridge.workers())
            ack = await bridge.send_command("b1", "set_behaviour", {"name": "copy"})
            assert ack.ok
            assert ack.result["behaviour"] == "copy"
            refused = await bridge.send_command("b1", "set_behaviour", {"name": "nope"})
            assert (refused.ok, refused.error) == (False, "bad_behaviour")
            unknown = await bridge.send_command("b1", "dance", {})
            assert unknown.error == "unknown_command"
            assert bridge.state("b1").behaviour == {"name": "copy"}  # only acked commands
        with pytest.raises(WorkerUnavailableError, match="nobody"):
            await bridge.send_command("nobody", "status")

    _run(test)


def test_a_worker_that_does_not_answer_times_out_clearly() -> None:
    async def test(bridge: Bridge) -> None:
        context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
        mute = context.socket(zmq.DEALER)
        mute.setsockopt(zmq.IDENTITY, b"mute")
        mute.connect(bridge.command_endpoint)
        mute.send_multipart(serialize(make_hello("mute", {"instance": "x"})))
        try:
            await _until(lambda: "mute" in bridge.workers())
            with pytest.raises(WorkerTimeoutError, match=r"did not answer status within 0\.2 s"):
                await bridge.send_command("mute", "status", timeout=0.2)
            with pytest.raises(TimeoutError):  # also an ordinary TimeoutError
                await bridge.send_command("mute", "status", timeout=0.05)
        finally:
            mute.close(linger=0)
            context.term()

    _run(test)


def test_telemetry_display_frames_and_connection_messages_fan_out() -> None:
    async def test(bridge: Bridge) -> None:
        display: list[Message] = []
        bridge.add_listener("display.", display.append)
        with bridge.subscribe("b2", ("telemetry", "worker")) as subscription, \
                Worker(_config(bridge, "b2", driver="virtual")):  # fmt: skip
            await _until(lambda: bridge.latest_telemetry("b2")[0] is not None)
            await _until(lambda: {m.type for m in display} >= {"face", "head"})
            telemetry, age = bridge.latest_telemetry("b2")
            assert telemetry is not None
            assert telemetry["booth"] == "b2"
            assert age is not None
            assert age < 2
            first = await asyncio.wait_for(subscription.get(), 5)
            assert (first.topic, first.type) == ("worker.b2", "worker_connected")
            second = await asyncio.wait_for(subscription.get(), 5)
            assert second.topic == "telemetry.b2"
        assert display[0].topic == "display.b2"
        assert bridge.latest_telemetry("nobody") == (None, None)

    _run(test)


def test_a_restarted_worker_gets_its_state_back_and_a_lost_one_is_reported() -> None:
    async def test(bridge: Bridge) -> None:
        bridge.stale_after = 1.0
        with bridge.subscribe("b3", ("worker",)) as events:
            with Worker(_config(bridge, "b3")):
                await _until(lambda: "b3" in bridge.workers())
                await bridge.send_command("b3", "set_behaviour",
                                          {"name": "copy", "params": {"delay": 1.5}})  # fmt: skip
                assert (await bridge.send_command("b3", "set_face", {"face_id": "kid"})).ok
            lost = await asyncio.wait_for(_next_of(events, "worker_lost"), 5)
            assert lost.body["connected"] is False
            with Worker(_config(bridge, "b3")) as again:
                restarted = await asyncio.wait_for(_next_of(events, "worker_restarted"), 5)
                assert restarted.body["restarts"] == 1
                await _until(lambda: again.behaviour.router.current_name == "copy")
                copy = again.behaviour.router.current
                # The restored copy runs at the delay it was given (describe() lists every
                # parameter of copy's design space, the others at their defaults).
                described = getattr(copy, "new", copy).describe()
                assert described["delay"] == 1.5
                assert described["channels"] == "all"

    _run(test)


async def _next_of(subscription: Subscription, kind: str) -> Message:
    async for message in subscription:
        if message.type == kind:
            return message
    raise AssertionError(f"subscription ended before {kind}")


def test_full_subscriber_queues_drop_the_oldest_display_frame_first() -> None:
    async def test() -> None:
        closed: list[Subscription] = []
        subscription = Subscription("b", ("display", "event"), 3, closed.append)
        for kind, topic in (("face", "display.b"), ("speech_start", "event.b"),
                            ("head", "display.b"), ("face", "display.b"),
                            ("speech_end", "event.b")):  # fmt: skip
            subscription.offer(Message(topic, kind), "b")
        subscription.offer(Message("display.other", "face"), "other")  # not this booth
        kinds = [subscription.get_nowait().type for _ in range(3)]  # type: ignore[union-attr]
        assert kinds == ["speech_start", "face", "speech_end"]
        assert subscription.dropped == 2
        subscription.close()
        assert closed == [subscription]
        with pytest.raises(StopAsyncIteration):
            await subscription.get()

    asyncio.run(test())
