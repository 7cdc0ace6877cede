"""The renderer stage: keyframes and playback in, the robot driven at a fixed rate.

Two threads. The receiver thread blocks on a SUB (agent keyframes from the behaviour stage,
``playback.*`` from playback), stores keyframes in the :class:`RenderCore` and queues
playback requests. The tick thread owns the driver and this stage's PUB: every tick it runs
queued requests and driver events (cheap emptiness checks when there are none), renders,
and publishes what was sent (``face.sent``, for recordings), speech and robot events
(``event.speech``/``event.robot``, worker timestamps), the virtual driver's display frames,
and once a second ``stats.renderer``.
"""

from __future__ import annotations

import math
import queue
import threading
import time
from collections import Counter, deque
from collections.abc import Callable
from typing import Any

import numpy as np
import zmq

from chameleons.worker.behaviours.base import HEAD_SLICE, VECTOR_SIZE
from chameleons.worker.drivers import (
    ROBOT_STATE,
    SPEECH_END,
    SPEECH_START,
    Driver,
    DriverEvent,
)
from chameleons.worker.drivers.virtual import Publish
from chameleons.worker.envelope import Message
from chameleons.worker.playback import lipsync_from_message
from chameleons.worker.renderer import RenderConfig, RenderCore, RenderLoop
from chameleons.worker.stage import (
    AGENT_TOPIC,
    FINAL_LINGER_MS,
    PLAYBACK_PREFIX,
    POLL_MS,
    SENT_TOPIC,
    Endpoints,
    receive_messages,
    send_message,
)

DriverFactory = Callable[[Publish], Driver]
STATS_INTERVAL = 1.0
_LATENCY_RING = 1024
_ENDED_PLAYS = 64  # recent plays whose end went out: a second end of one is dropped


class RendererStage:
    name = "renderer"

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints,
        driver_factory: DriverFactory, config: RenderConfig | None = None,
    ) -> None:  # fmt: skip
        self.context, self.endpoints = context, endpoints
        self.config = config or RenderConfig()
        self._driver_factory = driver_factory
        self.driver: Driver | None = None
        self.core: RenderCore | None = None
        self.loop = RenderLoop(self.config.tick_rate, self._on_tick)
        self.errors: Counter[str] = Counter()
        self.speaking: str | None = None
        # The server's id of the play loaded for the robot, and of the one speaking: a
        # driver event of another play (the same prompt played again) is that play's.
        self.loaded_play: str | None = None
        self.speaking_play: str | None = None
        # Each play gets exactly one end: the first one given (this stage's own, when a new
        # prompt cuts it short, or the driver's). Later events of an ended play are dropped.
        self._ended: deque[str] = deque(maxlen=_ENDED_PLAYS)
        self.ready = threading.Event()  # set once the first tick ran
        self._requests: queue.SimpleQueue[tuple[Any, ...]] = queue.SimpleQueue()
        self._events: queue.SimpleQueue[DriverEvent] = queue.SimpleQueue()
        self._pub: zmq.Socket[bytes] | None = None
        self._latency = np.full(_LATENCY_RING, np.nan)
        self._latency_count = 0
        self._sent = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._seq = 0
        self._next_stats = 0.0
        self._stats_ticks = 0

    # --- lifecycle (the calling thread becomes the tick thread) ---------------------------
    def run(self, stop: threading.Event) -> None:
        self._pub = self.context.socket(zmq.PUB)
        self._pub.setsockopt(zmq.LINGER, 0)
        self._pub.bind(self.endpoints.render)
        self.driver = self._driver_factory(self._publish)
        self.core = RenderCore(self.driver, self.config)
        self.driver.bind_events(self._events.put)
        receiver = threading.Thread(target=self._receive, args=(stop,), name="renderer-receive",
                                    daemon=True)  # fmt: skip
        receiver.start()
        try:
            self.driver.start()
            self._next_stats = time.monotonic() + STATS_INTERVAL
            self.loop.run(stop)
        finally:
            receiver.join(timeout=5)
            self.driver.close()
            self._handle_driver_events()
            self._pub.close(linger=FINAL_LINGER_MS)

    def _publish(self, message: Message) -> None:
        if self._pub is not None and not send_message(self._pub, message):
            self.errors["publish_dropped"] += 1

    # --- receiver thread -------------------------------------------------------------------
    def _receive(self, stop: threading.Event) -> None:
        sub = self.context.socket(zmq.SUB)
        sub.setsockopt(zmq.LINGER, 0)
        for prefix in (AGENT_TOPIC, PLAYBACK_PREFIX):
            sub.setsockopt(zmq.SUBSCRIBE, prefix.encode())
        sub.connect(self.endpoints.agent)
        sub.connect(self.endpoints.playback)
        try:
            while not stop.is_set():
                if sub.poll(POLL_MS):
                    for message in receive_messages(sub, self.errors):
                        self._on_message(message)
        finally:
            sub.close(linger=0)

    def _on_message(self, message: Message) -> None:
        assert self.core is not None
        try:
            if message.topic == AGENT_TOPIC:
                vector = message.array()
                t, used = float(message.body["t"]), message.body.get("input_time")
                lag = float(message.body.get("lag") or 0.0)
                if vector.shape != (VECTOR_SIZE,) or not np.all(np.isfinite(vector)):
                    raise ValueError("bad keyframe vector")
                self.core.push_keyframe(t, vector, math.nan if used is None else float(used), lag)
            elif message.topic == "playback.prompt":
                body = message.body
                self._requests.put(("prompt", str(body["prompt_id"]), str(body["audio_url"]),
                                    lipsync_from_message(message), body.get("text"),
                                    body.get("voice"), body.get("play_id") or None))  # fmt: skip
            elif message.topic == "playback.stop":
                self._requests.put(("stop",))
            elif message.topic == "playback.retry":
                self._requests.put(("retry",))
            elif message.topic == "playback.face":
                renderer = message.body.get("renderer")
                self._requests.put(("face", str(message.body["face_id"]),
                                    str(renderer) if renderer else None))  # fmt: skip
            elif message.topic == "playback.speech":
                self._requests.put(("speech", str(message.body["event"]),
                                    message.body.get("prompt_id"),
                                    message.body.get("play_id") or None))  # fmt: skip
            else:
                self.errors["unknown_topic"] += 1
        except (KeyError, TypeError, ValueError):
            self.errors[f"bad_{message.topic}"] += 1

    # --- tick thread -----------------------------------------------------------------------
    def _on_tick(self, due: float, now: float) -> None:
        core = self.core
        assert core is not None
        # The driver's events first: a prompt that started or ended is known as such before
        # a new prompt replaces it (else its start or end raced the replacement).
        if not self._events.empty():
            self._handle_driver_events()
        if not self._requests.empty():
            self._run_requests()
        input_time = core.tick(due)
        if self.speaking is not None and due >= core.lipsync.end:
            # A driver that cannot report the end of the audio: speech ends with the curves.
            self._speech_event(SPEECH_END, core.lipsync.end, self.speaking)
        sent = time.monotonic()
        if math.isfinite(input_time):
            # The pipeline's own latency: a copy's intended delay is not latency. (An output
            # interpolated towards a newer frame than its schedule reports is not early.)
            late = max(0.0, sent - input_time - core.lag)
            self._latency[self._latency_count % _LATENCY_RING] = late
            self._latency_count += 1
        self._publish_sent(due, input_time)
        if sent >= self._next_stats:
            self._next_stats += STATS_INTERVAL
            self._publish(Message("stats.renderer", "stats", 0, self.name, sent, self.stats()))
        self.ready.set()

    def _publish_sent(self, due: float, input_time: float) -> None:
        assert self.core is not None
        self._sent[:] = self.core.agent
        self._sent[HEAD_SLICE] = self.core.filter.output
        shown = self.driver.shown_weight() if self.driver is not None else 1.0
        if shown != 1.0:  # a robot waking from its neutral after a switch shows less
            self._sent *= np.float32(shown)
        self._seq += 1
        body = {"t": due, "input_time": input_time if math.isfinite(input_time) else None}
        self._publish(Message(SENT_TOPIC, "sent", self._seq, self.name, due, body,
                              self._sent.astype("<f4").tobytes()))  # fmt: skip

    def _run_requests(self) -> None:
        assert self.driver is not None
        assert self.core is not None
        while not self._requests.empty():
            request = self._requests.get_nowait()
            kind = request[0]
            if kind == "prompt":
                _, prompt_id, url, curve, text, voice, play_id = request
                if self.speaking is not None:  # cut short by the new prompt: not "played"
                    self.driver.stop_audio()
                    self._speech_event(SPEECH_END, time.monotonic(), self.speaking,
                                       outcome="interrupted")  # fmt: skip
                self.core.lipsync.load(prompt_id, curve)
                self.loaded_play = play_id
                if text:  # typed speech in the robot's own TTS voice
                    self.driver.speak_text(prompt_id, str(text), voice and str(voice), play_id)
                else:
                    self.driver.play_audio(prompt_id, url, play_id)
            elif kind == "stop":
                self.driver.stop_audio()
                if self.speaking is not None and not self.driver.reports_speech_end:
                    self._speech_event(SPEECH_END, time.monotonic(), self.speaking,
                                       outcome="stopped")  # fmt: skip
            elif kind == "face":
                self.driver.set_face(request[1], request[2])
            elif kind == "speech":
                self.driver.remote_speech(request[1], request[2], request[3])
            elif kind == "retry":
                self.driver.retry()

    def _handle_driver_events(self) -> None:
        assert self.core is not None
        while not self._events.empty():
            event = self._events.get_nowait()
            if event.kind in (SPEECH_START, SPEECH_END) and self._replaced(event):
                # A replaced play's late start or end: report it as its own (unless it has
                # ended already), keep the current play's lip-sync and speaking state.
                self._publish_speech(event.kind, event.time, **event.body)
            elif event.kind == SPEECH_START and self.loaded_play in self._ended:
                self.errors["late_speech_start"] += 1  # it ended (stopped) before it started
            elif event.kind == SPEECH_START:
                prompt = event.body.get("prompt_id") or self.core.lipsync.prompt_id
                self.core.lipsync.begin(event.time)
                self.speaking, self.speaking_play = prompt or "", self.loaded_play
                self._publish_speech(SPEECH_START, event.time, prompt_id=prompt,
                                     play_id=self.loaded_play)  # fmt: skip
                if not self.driver or not self.driver.reports_speech_end:
                    self.core.lipsync.finish(self.core.lipsync.curve_end())
            elif event.kind == SPEECH_END:
                prompt = event.body.get("prompt_id") or self.speaking
                self._speech_event(SPEECH_END, event.time, prompt, **event.body)
            elif event.kind == ROBOT_STATE:
                self._publish_event("event.robot", ROBOT_STATE, event.time, **event.body)

    def _replaced(self, event: DriverEvent) -> bool:
        """The event belongs to a play other than the loaded one: by its play id, or (a
        server that sends none) an end of another prompt than the current one."""
        assert self.core is not None
        play = event.body.get("play_id")
        if play and self.loaded_play:
            return bool(play != self.loaded_play)
        prompt = event.body.get("prompt_id") or self.speaking
        return event.kind == SPEECH_END and prompt not in (
            self.speaking,
            self.core.lipsync.prompt_id,
        )

    def _speech_event(self, kind: str, when: float, prompt: str | None, **extra: Any) -> None:
        """The end of the speaking (else the loaded) play."""
        assert self.core is not None
        self.core.lipsync.finish(when)
        play = self.speaking_play if self.speaking is not None else self.loaded_play
        self.speaking = self.speaking_play = None
        extra.pop("prompt_id", None)
        extra.pop("play_id", None)
        self._publish_speech(kind, when, prompt_id=prompt, play_id=play, **extra)

    def _publish_speech(self, kind: str, when: float, **body: Any) -> None:
        """A speech start or end, unless its play has had its end (counted, dropped)."""
        play = body.get("play_id")
        if play and play in self._ended:
            self.errors[f"late_{kind}"] += 1
            return
        if play and kind == SPEECH_END:
            self._ended.append(play)
        self._publish_event("event.speech", kind, when, **body)

    def _publish_event(self, topic: str, kind: str, when: float, **body: Any) -> None:
        wall = time.time() - (time.monotonic() - when)
        self._publish(Message(topic, kind, 0, self.name, when,
                              {"worker_time": when, "wall_time": wall, **body}))  # fmt: skip

    def stats(self) -> dict[str, Any]:
        assert self.core is not None
        assert self.driver is not None
        loop_stats = self.loop.stats
        summary = loop_stats.summary()
        recent = self._latency[~np.isnan(self._latency)]
        latency = float(np.median(recent) * 1e3) if recent.size else None
        return {**summary, "tick_rate_hz": summary["ticks"] / STATS_INTERVAL,
                "missed_ticks": loop_stats.missed, "ticks_total": loop_stats.count,
                "capture_to_send_ms": latency, "keyframe_underruns": self.core.underruns,
                "fir_group_delay_ms": self.core.filter.group_delay * 1e3,
                "robot_state": self.driver.state, "robot_connected": self.driver.connected,
                "speaking": self.speaking is not None, "prompt_id": self.speaking,
                "driver": {"name": self.driver.name, **self.driver.stats()},
                "errors": dict(self.errors)}  # fmt: skip
