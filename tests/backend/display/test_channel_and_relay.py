"""The display channel (fan-out, state for late joiners, back-pressure) and the relay from
the worker's real ``virtual`` driver."""

from __future__ import annotations

import asyncio
import threading
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from chameleons.backend.display import channel as channel_module
from chameleons.backend.display.channel import DisplayChannel
from chameleons.backend.display.protocol import (
    Message,
    face_message,
    play_audio_message,
    set_face_message,
)
from chameleons.backend.display.relay import (
    RelayError,
    display_message,
    forward_speech_events,
    relay_envelope,
    speech_command_body,
)
from chameleons.worker.drivers.virtual import VirtualDriver
from chameleons.worker.envelope import Message as Envelope
from chameleons.worker.envelope import deserialize, serialize
from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES

BOOTH = "booth-1"


def run(coroutine: Any) -> Any:
    """``asyncio.run`` in a thread of its own (Playwright's sync API, when browser tests ran
    first in this process, leaves an event loop running in the main thread)."""
    result: list[Any] = []
    errors: list[BaseException] = []

    def target() -> None:
        try:
            result.append(asyncio.run(coroutine))
        except BaseException as exc:
            errors.append(exc)

    thread = threading.Thread(target=target)
    thread.start()
    thread.join(timeout=30)
    if errors:
        raise errors[0]
    return result[0]


def test_late_joiners_get_the_face_and_last_frame_first() -> None:
    async def scenario() -> list[Message]:
        channel = DisplayChannel()
        channel.publish(BOOTH, set_face_message("face-2"))
        channel.publish(BOOTH, face_message([0.5] * N_BLENDSHAPES))
        with channel.subscribe(BOOTH) as subscription:
            return [await asyncio.wait_for(subscription.get(), 5) for _ in range(2)]

    first, second = run(scenario())
    assert first == set_face_message("face-2")
    assert second["type"] == "face"
    assert second["bs"] == [0.5] * N_BLENDSHAPES


def test_a_slow_page_loses_old_frames_never_commands() -> None:
    async def scenario() -> tuple[list[Message], int]:
        channel = DisplayChannel(queue_limit=4)
        with channel.subscribe(BOOTH) as subscription:
            for k in range(10):
                channel.publish(BOOTH, face_message([k / 10] * N_BLENDSHAPES))
                if k == 3:
                    channel.publish(BOOTH, play_audio_message("p#1", "/a.mp3"))
            channel.publish(BOOTH, set_face_message("face-3"))  # queue full of frames
            got = [await asyncio.wait_for(subscription.get(), 5) for _ in range(4)]
            return got, subscription.dropped

    got, dropped = run(scenario())
    assert [m["type"] for m in got] == ["play_audio", "face", "face", "set_face"]
    assert [m["bs"][0] for m in got[1:3]] == [0.8, 0.9]  # the newest frames survive
    assert dropped == 8


def test_publish_from_another_thread_reaches_the_page() -> None:
    async def scenario() -> Message:
        channel = DisplayChannel()
        with channel.subscribe(BOOTH) as subscription:
            thread = threading.Thread(
                target=channel.publish, args=(BOOTH, set_face_message("face-4"))
            )
            thread.start()
            message = await asyncio.wait_for(subscription.get(), timeout=5)
            thread.join()
            return message

    assert run(scenario()) == set_face_message("face-4")


def virtual_driver_envelopes() -> list[Envelope]:
    sent: list[Envelope] = []
    driver = VirtualDriver(BOOTH, sent.append, head_rate=1e6)
    shapes = np.zeros(N_BLENDSHAPES, dtype=np.float32)
    shapes[BLENDSHAPE_INDEX["jawOpen"]] = 0.75
    driver.send_face(shapes)
    driver.send_head(12.5, -3.0, 1.0)
    driver.set_face("face-2")
    driver.play_audio("hello", "/media/prompts/m1/audio/hello.mp3?key=k")
    driver.stop_audio()
    # Through the real wire format, as the bridge receives them.
    return [deserialize(serialize(envelope)) for envelope in sent]


def test_virtual_driver_envelopes_become_page_messages() -> None:
    face, head, set_face, play, stop = (display_message(e) for e in virtual_driver_envelopes())
    assert face["type"] == "face"
    assert face["bs"][BLENDSHAPE_INDEX["jawOpen"]] == 0.75
    assert "head" not in face
    assert face["t"] > 0
    assert (head["type"], head["head"]) == ("head", [12.5, -3.0, 1.0])
    assert set_face == set_face_message("face-2")
    assert (play["type"], play["prompt_id"], play["url"]) == (
        "play_audio", "hello", "/media/prompts/m1/audio/hello.mp3?key=k",
    )  # fmt: skip
    assert play["play_id"].startswith("hello#")
    assert stop["type"] == "stop_audio"


def test_the_worker_s_play_id_reaches_the_page_and_comes_back_to_the_worker() -> None:
    """The same prompt played twice: each play keeps the id the server gave it, on the page
    and back in the page's speech reports; an id the relay made itself stays here."""
    sent: list[Envelope] = []
    driver = VirtualDriver(BOOTH, sent.append)
    driver.play_audio("hello", "/a.mp3", "play-41")
    driver.play_audio("hello", "/a.mp3", "play-42")
    driver.play_audio("hello", "/a.mp3")  # a server that sends no play id
    first, second, bare = (display_message(deserialize(serialize(e))) for e in sent)
    assert (first["play_id"], second["play_id"]) == ("play-41", "play-42")
    assert bare["play_id"].startswith("hello#")
    report = {"type": "speech", "event": "end", "prompt_id": "hello", "reason": "interrupted"}
    assert speech_command_body({**report, "play_id": "play-41"}) == {
        "event": "end", "prompt_id": "hello", "play_id": "play-41",
    }  # fmt: skip
    assert speech_command_body({**report, "play_id": bare["play_id"]}) == {
        "event": "end", "prompt_id": "hello",
    }  # fmt: skip


@pytest.mark.parametrize(
    ("envelope", "reason"),
    [
        (Envelope("display.b", "face", payload=b"\x00" * 8), "short_face"),
        (Envelope("display.b", "head", body={"yaw": 1}), "bad_head"),
        (Envelope("display.b", "set_face", body={"face_id": "face-9"}), "unknown_face"),
        (Envelope("display.b", "play_audio", body={}), "bad_play_audio"),
        (Envelope("display.b", "dance"), "unknown_type"),
    ],
)
def test_unusable_envelopes_are_refused_with_a_reason(envelope: Envelope, reason: str) -> None:
    with pytest.raises(RelayError) as caught:
        display_message(envelope)
    assert caught.value.reason == reason
    channel = DisplayChannel()
    assert not relay_envelope(channel, envelope)
    assert channel.counters[f"relay.{reason}"] == 1


def test_relay_names_the_curves_for_the_audio() -> None:
    envelope = Envelope("display.b", "play_audio", body={"prompt_id": "hi", "url": "/a/hi.wav"})
    message = display_message(envelope, lambda url: url.replace(".wav", ".csv"))
    assert message["lipsync_url"] == "/a/hi.csv"
    assert display_message(envelope)["lipsync_url"] is None


def test_this_servers_media_reaches_the_page_as_paths() -> None:
    """A booth screen on another computer opens the server by its LAN name: the server's
    own URLs (public URL default http://127.0.0.1:8000) must not send it to itself."""
    own = "http://127.0.0.1:8000/media/prompts/m1/audio/hi.wav?key=k"
    envelope = Envelope("display.b", "play_audio", body={"prompt_id": "hi", "url": own})
    message = display_message(envelope, lambda url: url.replace(".wav", ".csv"),
                              served_from="http://127.0.0.1:8000/")  # fmt: skip
    assert message["url"] == "/media/prompts/m1/audio/hi.wav?key=k"
    assert message["lipsync_url"] == "/media/prompts/m1/audio/hi.csv?key=k"
    elsewhere = Envelope("display.b", "play_audio",
                         body={"url": "http://127.0.0.1:80001/x.wav"})  # fmt: skip
    kept = display_message(elsewhere, served_from="http://127.0.0.1:8000")
    assert kept["url"] == "http://127.0.0.1:80001/x.wav"  # another origin stays whole


def test_relay_publishes_to_the_envelopes_booth() -> None:
    async def scenario() -> Message:
        channel = DisplayChannel()
        with channel.subscribe("booth-9") as subscription:
            envelope = Envelope("display.booth-9", "set_face", body={"face_id": "face-3"})
            assert relay_envelope(channel, envelope)
            return await asyncio.wait_for(subscription.get(), 5)

    assert run(scenario()) == set_face_message("face-3")


def test_speech_events_are_forwarded_as_worker_commands() -> None:
    sent: list[tuple[str, str, dict[str, Any]]] = []

    async def send(booth: str, command: str, body: dict[str, Any]) -> None:
        sent.append((booth, command, body))

    async def scenario() -> None:
        channel = DisplayChannel()
        forward_speech_events(channel, send)
        await channel.report(BOOTH, {"type": "telemetry", "fps": 60})
        speech = {"type": "speech", "event": "end", "play_id": "x#1", "prompt_id": "x"}
        await channel.report(BOOTH, speech)
        assert channel.telemetry(BOOTH) == {"type": "telemetry", "fps": 60}

    run(scenario())
    assert sent == [(BOOTH, "speech_event", {"event": "end", "prompt_id": "x"})]


def test_the_condition_s_renderer_reaches_the_page_and_stays_for_late_pages() -> None:
    sent: list[Envelope] = []
    driver = VirtualDriver(BOOTH, sent.append)
    driver.set_face("face-3", "3d")
    driver.set_face("face-1")
    three_d, plain = (display_message(deserialize(serialize(e))) for e in sent)
    assert three_d == {"type": "set_face", "face": "face-3", "renderer": "3d"}
    assert plain == {"type": "set_face", "face": "face-1"}
    channel = DisplayChannel()
    body = {"face_id": "face-1", "renderer": "4d"}
    bad = Envelope("display." + BOOTH, "set_face", 1, "renderer", body=body)
    assert relay_envelope(channel, bad) is False
    assert channel.counters["relay.unknown_renderer"] == 1
    with pytest.raises(ValueError, match="unknown renderer"):
        set_face_message("face-1", "4d")

    async def late_page() -> Message:
        channel.publish(BOOTH, three_d)
        with channel.subscribe(BOOTH) as page:
            return await page.get()

    assert run(late_page()) == three_d
    assert channel.current_face(BOOTH) == "face-3"


def test_a_display_gone_while_it_speaks_ends_the_play_for_it(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """The last page of the booth goes mid-play and stays away: the channel reports that
    play's end with reason display_closed (forwarded to the worker like the page's own),
    and says the play was cut short. A page that comes back within the grace reports the
    end itself: nothing is reported for it."""
    monkeypatch.setattr(channel_module, "DISPLAY_GONE_GRACE_SECONDS", 0.05)

    async def scenario() -> tuple[list[Message], bool, bool, bool]:
        channel = DisplayChannel()
        ended = asyncio.Event()
        heard: list[Message] = []

        def listener(_booth: str, message: Message) -> None:
            heard.append(message)
            if message.get("reason") == "display_closed":
                ended.set()

        channel.add_listener(listener)
        start = {"type": "speech", "event": "start", "prompt_id": "intro", "play_id": "play-7"}
        with channel.subscribe(BOOTH):
            await channel.report(BOOTH, start)
        await asyncio.wait_for(ended.wait(), 10)
        cut = channel.cut_short(BOOTH, "intro", "play-7")
        other = channel.cut_short(BOOTH, "intro", "play-8")
        # A page that reconnects at once: no end is made up for its play.
        again = {**start, "play_id": "play-9"}
        with channel.subscribe(BOOTH):
            await channel.report(BOOTH, again)
        with channel.subscribe(BOOTH):
            await asyncio.sleep(0.3)  # several graces long: a wrong report would have come
            reconnected = channel.cut_short(BOOTH, "intro", "play-9")
        return heard, cut, other, reconnected

    heard, cut, other, reconnected = run(scenario())
    ends = [m for m in heard if m.get("event") == "end"]
    assert ends == [{"type": "speech", "event": "end", "prompt_id": "intro",
                     "play_id": "play-7", "reason": "display_closed"}]  # fmt: skip
    assert (cut, other, reconnected) == (True, False, False)


def test_the_paint_rate_is_the_median_of_the_page_s_reports_since_a_moment(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """What the booth check judges the display's smoothness by: the median frames a second
    of the reports from a second before ``since`` on (a report covers the second before it),
    not the latest one, which a page painting a frame or two a second passes most seconds."""
    clock = {"now": 100.0}
    monkeypatch.setattr(channel_module, "time", SimpleNamespace(monotonic=lambda: clock["now"]))

    async def scenario() -> list[float | None]:
        channel = DisplayChannel()
        seen = [channel.paint_rate(BOOTH, 0.0)]  # no report yet
        for fps in (60, 60, 2, 1, 0, 2, True, "60"):  # a bool or a string is not a rate
            await channel.report(BOOTH, {"type": "telemetry", "fps": fps})
            clock["now"] += 1.0
        await channel.report("booth-2", {"type": "telemetry", "fps": 60})
        # reports at 100..107; since 103.0 takes those from 102 on: 2, 1, 0, 2
        seen += [channel.paint_rate(BOOTH, 103.0), channel.paint_rate(BOOTH, 100.0),
                 channel.paint_rate(BOOTH, 200.0)]  # fmt: skip
        return seen

    assert run(scenario()) == [None, 1.5, 2.0, None]
