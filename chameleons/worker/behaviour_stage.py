"""The behaviour stage: participant frames in, agent keyframes out.

It samples the current behaviour on the renderer's tick grid (times ``k / tick_rate`` on the
monotonic clock) a few ticks ahead (``lookahead``) and publishes each sample as a keyframe
(topic ``face.agent``, body ``{"t", "input_time"}``, payload 61 float32). Publishing ahead
makes the renderer's output independent of this stage's scheduling and of the socket hop:
at tick ``k`` the keyframe for exactly that time is already there. The head channels are
sampled ``head_lead`` seconds later than the face (the renderer's FIR group delay), so after
the filter the head is exactly as late as the face.

Each keyframe also carries ``lag``: the seconds the behaviour means its output to trail its
input (``copy``: its delay), which the renderer leaves out of its capture-to-send latency.
The participant's neutral head pose (``copy`` re-centres on it) is measured here from the
participant frames; ``recentre_head`` measures it afresh, and each new neutral is published
as an ``event.behaviour`` ``head_neutral`` event (logged by the server with the session).
What the behaviour drew at random (``copy``'s bouts and jittered delays) is published as an
``event.behaviour`` ``copy_draw`` event per draw, when its output first shows it (the server
logs it as ``robot.copy_draw`` of the running interaction; docs/design-space.md).
"""

from __future__ import annotations

import math
import threading
import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import zmq

from chameleons.worker.behaviours.base import HEAD_SLICE, VECTOR_SIZE, BehaviourError
from chameleons.worker.behaviours.router import BehaviourRouter, build_context
from chameleons.worker.control import RECENTRE_HEAD, SET_BEHAVIOUR, STATUS, CommandError
from chameleons.worker.envelope import EnvelopeError, Message, message_frame
from chameleons.worker.stage import (
    AGENT_TOPIC,
    PARTICIPANT_TOPIC,
    POLL_MS,
    CommandPort,
    Endpoints,
    RateMeter,
    receive_messages,
    send_message,
)

STATS_INTERVAL = 1.0


@dataclass(frozen=True, slots=True)
class BehaviourStageConfig:
    tick_rate: float = 125.0
    lookahead_ticks: int = 5
    crossfade_seconds: float = 0.3
    history_seconds: float = 12.0
    head_lead: float = 0.0  # the renderer's FIR group delay, compensated here
    initial: str = "still"
    initial_params: Mapping[str, Any] = field(default_factory=dict)
    locations: Any = None  # this machine's data_dir/prompts_dir, for marked clip paths
    rotation_factor: float | None = None  # of Live Link take CSVs replayed as clips
    recentre_head: bool = True  # the booth's head_recentre setting (copy re-centres the head)
    head_calibration_s: float = 20.0  # the neutral head pose: mean of this many seconds
    mirror: bool = True  # the booth's mirror setting (frames arrive mirrored); copy's default


class BehaviourStage:
    name = "behaviour"

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints,
        config: BehaviourStageConfig | None = None, *, clock: Callable[[], float] = time.monotonic,
    ) -> None:  # fmt: skip
        self.context, self.endpoints = context, endpoints
        self.config = config or BehaviourStageConfig()
        self.clock = clock
        self.period = 1.0 / self.config.tick_rate
        behaviours = build_context(self.config.history_seconds, locations=self.config.locations,
                                   rotation_factor=self.config.rotation_factor,
                                   recentre_head=self.config.recentre_head,
                                   head_calibration_s=self.config.head_calibration_s,
                                   input_mirrored=self.config.mirror)  # fmt: skip
        self.router = BehaviourRouter(
            behaviours,
            self.config.crossfade_seconds,
            initial=self.config.initial, params=self.config.initial_params, start=clock(),
        )  # fmt: skip
        self.errors: Counter[str] = Counter()
        self.frames = RateMeter()
        self.keyframes_out = 0
        self._next = math.ceil(clock() / self.period)  # tick index of the next keyframe
        self._vector = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._lead = np.zeros(VECTOR_SIZE, dtype=np.float32)
        self._seq = 0
        self._input_fps = 0.0

    def run(self, stop: threading.Event) -> None:
        sub = self.context.socket(zmq.SUB)
        sub.setsockopt(zmq.LINGER, 0)
        sub.setsockopt(zmq.SUBSCRIBE, PARTICIPANT_TOPIC.encode())
        sub.connect(self.endpoints.participant)
        pub = self.context.socket(zmq.PUB)
        pub.setsockopt(zmq.LINGER, 0)
        pub.bind(self.endpoints.agent)
        port = CommandPort(self.context, self.endpoints.stage_control, self.name,
                           {SET_BEHAVIOUR: self._set_behaviour, STATUS: self._status,
                            RECENTRE_HEAD: self._recentre_head})  # fmt: skip
        poller = zmq.Poller()
        poller.register(sub, zmq.POLLIN)
        poller.register(port.socket, zmq.POLLIN)
        next_stats = self.clock() + STATS_INTERVAL
        self._next = max(self._next, math.ceil(self.clock() / self.period))  # no backlog
        try:
            while not stop.is_set():
                wait = (self._next * self.period - self.config.lookahead_ticks * self.period
                        - self.clock())  # fmt: skip
                events = dict(poller.poll(min(POLL_MS, max(0, math.ceil(wait * 1000)))))
                if sub in events:
                    self._take_frames(receive_messages(sub, self.errors))
                if port.socket in events:
                    port.handle_pending()
                if self.router.context.head_neutral.changed:
                    send_message(pub, self._neutral_message())
                self._publish_due(pub)
                for report in self.router.realised():
                    send_message(pub, self._draw_message(report))
                if self.clock() >= next_stats:
                    next_stats += STATS_INTERVAL
                    send_message(pub, self._stats_message())
        finally:
            for socket in (sub, pub):
                socket.close(linger=0)
            port.close()

    def _take_frames(self, messages: list[Message]) -> None:
        for message in messages:
            try:
                frame = message_frame(message)
            except EnvelopeError as exc:
                self.errors[exc.reason] += 1
                continue
            self.router.on_participant(frame)
            self.frames.count += 1

    def _publish_due(self, pub: zmq.Socket[bytes]) -> None:
        horizon = self.clock() + self.config.lookahead_ticks * self.period
        if self._next * self.period < horizon - 1.0:  # stalled for a second: skip ahead
            self.errors["stalled"] += 1
            self._next = math.ceil((horizon - self.config.lookahead_ticks * self.period)
                                   / self.period)  # fmt: skip
        while self._next * self.period <= horizon:
            t = self._next * self.period
            send_message(pub, self.keyframe(t))
            self._next += 1

    def keyframe(self, t: float) -> Message:
        """Sample the router for local time ``t`` (head ``head_lead`` later) as a message."""
        input_time = self.router.sample(t, self._vector)
        lead = self.config.head_lead
        if lead > 0:
            self.router.sample(t + lead, self._lead)
            self._vector[HEAD_SLICE] = self._lead[HEAD_SLICE]
        self.router.advance(t)
        self._seq += 1
        self.keyframes_out += 1
        body: dict[str, Any] = {"t": t, "input_time": None}
        if math.isfinite(input_time):
            body.update(input_time=input_time, lag=self.router.current.lag)
        return Message(AGENT_TOPIC, "keyframe", self._seq, self.name, self.clock(), body,
                       self._vector.astype("<f4").tobytes())  # fmt: skip

    def _set_behaviour(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        params = body.get("params") or {}
        switch_at = self._next * self.period  # the first keyframe not yet published
        try:
            self.router.set_behaviour(str(body["name"]), params, switch_at)
        except BehaviourError as exc:
            raise CommandError("bad_behaviour", str(exc)) from exc
        return {"behaviour": self.router.current_name, "params": params, "switch_at": switch_at,
                "crossfade": self.router.crossfade_seconds, "head": self._head()}  # fmt: skip

    def _recentre_head(self, body: Mapping[str, Any]) -> Mapping[str, Any]:
        """A new participant (no ``seconds``): measure the neutral afresh over the next
        frames. The booth check (``seconds``): the mean of the last ``seconds`` of frames."""
        context = self.router.context
        seconds = body.get("seconds")
        if seconds is None:  # the new participant's frames: those captured from now on
            context.head_neutral.restart(since=self.clock())
        elif not (isinstance(seconds, int | float) and 0 < seconds <= context.history_seconds):
            raise CommandError("bad_field", f"seconds must be within 0..{context.history_seconds}")
        elif not context.head_neutral.capture(context.history, self.clock(), float(seconds)):
            raise CommandError("no_frames", f"no participant frames in the last {seconds:g} s")
        return self._head()

    def _head(self) -> dict[str, Any]:
        """How the copied head is processed: re-centred or not, and on which pose."""
        context = self.router.context
        return {"recentre": context.recentre_head, "neutral": context.head_neutral.describe()}

    def _neutral_message(self) -> Message:
        """The neutral head pose froze: tell the server (it logs it with the session)."""
        self.router.context.head_neutral.changed = False
        now = self.clock()
        body = {"worker_time": now, "wall_time": time.time() - (time.monotonic() - now),
                **self._head()}  # fmt: skip
        return Message("event.behaviour", "head_neutral", 0, self.name, now, body)

    def _draw_message(self, report: Mapping[str, Any]) -> Message:
        """A random draw the output reached: when (``worker_time``, ``wall_time``) and what."""
        now = self.clock()
        when = float(report["t"])
        body = {"worker_time": when, "wall_time": time.time() - (time.monotonic() - when),
                "behaviour": self.router.current_name,
                **{k: v for k, v in report.items() if k != "t"}}  # fmt: skip
        return Message("event.behaviour", "copy_draw", 0, self.name, now, body)

    def _status(self, _body: Mapping[str, Any]) -> Mapping[str, Any]:
        return self._stats_body()

    def _stats_body(self) -> dict[str, Any]:
        history = self.router.context.history
        return {"behaviour": self.router.current_name, "params": self.router.current_params,
                "input_fps": self._input_fps, "frames_in": self.frames.count,
                "keyframes_out": self.keyframes_out, "errors": dict(self.errors),
                "history_frames": len(history), "out_of_order": history.out_of_order,
                "history_underruns": history.underruns, "head": self._head()}  # fmt: skip

    def _stats_message(self) -> Message:
        self._input_fps = self.frames.rate(self.clock())
        return Message("stats.behaviour", "stats", 0, self.name, self.clock(), self._stats_body())
