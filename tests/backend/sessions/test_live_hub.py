"""The live hub: delivery from any thread, never blocking, resync for slow listeners, and
publishing only what a transaction actually committed."""

from __future__ import annotations

import asyncio
import threading

from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker
from chameleons.backend.events import repository as events
from chameleons.backend.events.hub import RESYNC, LiveHub, session_channel
from chameleons.backend.events.unit_of_work import attach_hub, write_session
from tests.support.factories import populate


def test_messages_from_another_thread_reach_only_their_channel() -> None:
    hub = LiveHub()

    async def scenario() -> list[dict[str, object]]:
        async with hub.subscribe("session:1") as one, hub.subscribe("session:2") as two:
            assert hub.subscriber_count("session:1") == 1

            def send() -> None:
                for n in range(3):
                    hub.publish("session:1", {"n": n})

            sender = threading.Thread(target=send)
            sender.start()
            sender.join()
            received = [await asyncio.wait_for(one.get(), 5) for _ in range(3)]
            assert two.drain() == []
        assert hub.subscriber_count("session:1") == 0
        return received

    assert asyncio.run(scenario()) == [{"n": 0}, {"n": 1}, {"n": 2}]


def test_a_slow_listener_gets_one_resync_instead_of_a_backlog() -> None:
    hub = LiveHub(queue_size=4)

    async def scenario() -> list[dict[str, object]]:
        async with hub.subscribe("c") as slow:
            for n in range(10):  # in the loop: delivered at once, never waiting
                hub.publish("c", {"n": n})
            return slow.drain()

    assert asyncio.run(scenario()) == [RESYNC, {"n": 9}]


def test_publishing_without_listeners_or_loop_is_a_no_op() -> None:
    hub = LiveHub()
    hub.publish("nobody", {"n": 1})
    with hub.presence("phone:1"):
        assert hub.present("phone:1") == 1
    assert hub.present("phone:1") == 0


def test_only_committed_events_are_published(engine: Engine) -> None:
    hub = LiveHub()
    factory = build_sessionmaker(engine)
    with factory.begin() as db:
        session_id = populate(db, participants=1).session_ids[0]

    def roll_back() -> None:
        with factory() as db:
            attach_hub(db, hub)
            events.record(db, "dropped", source="test", session_id=session_id)
            db.rollback()

    def commit() -> None:
        with write_session(factory, hub) as db:
            events.record(db, "kept", source="test", session_id=session_id)

    async def scenario() -> list[dict[str, object]]:
        async with hub.subscribe(session_channel(session_id)) as listener:
            await asyncio.to_thread(roll_back)
            await asyncio.to_thread(commit)
            message = await asyncio.wait_for(listener.get(), 5)
            return [message, *listener.drain()]

    received = asyncio.run(scenario())
    assert [m["event"]["kind"] for m in received] == ["kept"]  # type: ignore[index]


def test_each_commit_publishes_once_whatever_the_sessions_and_threads(engine: Engine) -> None:
    """The commit listeners are the ``Session`` class's (``unit_of_work``), so every session
    hears every commit: sessions attached at once on many threads, each attached twice,
    publish each of their events exactly once, and a session never attached publishes
    nothing."""
    hub = LiveHub()
    factory = build_sessionmaker(engine)
    with factory.begin() as db:
        session_id = populate(db, participants=1).session_ids[0]

    def commit(kind: str) -> None:
        with write_session(factory, hub) as db:
            attach_hub(db, hub)  # a second time: still one publication
            events.record(db, kind, source="test", session_id=session_id)

    def unattached() -> None:
        with factory.begin() as db:
            events.record(db, "silent", source="test", session_id=session_id)

    kinds = [f"kept-{i}" for i in range(8)]

    async def scenario() -> list[str]:
        async with hub.subscribe(session_channel(session_id)) as listener:
            await asyncio.gather(*(asyncio.to_thread(commit, k) for k in kinds))
            await asyncio.to_thread(unattached)
            await asyncio.to_thread(commit, "last")
            published: list[str] = []
            while "last" not in published:  # "last" is committed after all the others
                published.append((await asyncio.wait_for(listener.get(), 5))["event"]["kind"])
            return [*published, *(m["event"]["kind"] for m in listener.drain())]

    assert sorted(asyncio.run(scenario())) == sorted([*kinds, "last"])
