"""Shared plumbing of the worker's stages: endpoints, command handling, counters.

Stages talk only through ZeroMQ sockets whose addresses come from :class:`Endpoints`, so the
same stage code runs as threads of one process (``inproc://``) or as separate processes or
hosts (``ipc://``/``tcp://``). Each stage binds its own PUB; the control hub binds a ROUTER
that stages connect a DEALER to (identity = stage name) for commands and acks.
"""

from __future__ import annotations

import contextlib
import logging
import threading
import time
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import zmq

from chameleons.worker.control import (
    CommandError,
    make_ack,
    make_error_ack,
    parse_command,
)
from chameleons.worker.envelope import EnvelopeError, Message, deserialize, serialize

log = logging.getLogger(__name__)

PARTICIPANT_TOPIC = "face.participant"
AGENT_TOPIC = "face.agent"
SENT_TOPIC = "face.sent"
PLAYBACK_PREFIX = "playback."
STATS_PREFIX = "stats."
EVENT_PREFIX = "event."
DISPLAY_PREFIX = "display."
POLL_MS = 100  # how often a blocked stage looks at its stop flag
# A stage's last words on stopping (robot closed, recording stopped) get this long to leave.
FINAL_LINGER_MS = 1000


@dataclass(frozen=True, slots=True)
class Endpoints:
    """Where each stage's sockets live. Capture receivers connect their PUBs to ``capture``;
    the participant bus re-publishes those frames on ``participant`` for every consumer."""

    capture: str
    participant: str
    agent: str
    playback: str
    render: str
    recorder: str
    stage_control: str

    @classmethod
    def inproc(cls, booth: str) -> Endpoints:
        return cls(**{name: f"inproc://chameleons-{booth}-{name}" for name in _NAMES})

    @classmethod
    def ipc(cls, booth: str, directory: Path) -> Endpoints:
        return cls(**{name: f"ipc://{directory}/{booth}-{name}.sock" for name in _NAMES})

    @classmethod
    def tcp(cls, host: str = "127.0.0.1", first_port: int = 15600) -> Endpoints:
        ports = {name: f"tcp://{host}:{first_port + i}" for i, name in enumerate(_NAMES)}
        return cls(**ports)


_NAMES = ("capture", "participant", "agent", "playback", "render", "recorder", "stage_control")

CommandHandler = Callable[[Mapping[str, Any]], Mapping[str, Any]]


class CommandPort:
    """A stage's DEALER to the control hub: reads commands, dispatches them through a
    handler table, answers every one with an ack or an error ack. Never raises."""

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoint: str, stage: str,
        handlers: Mapping[str, CommandHandler],
    ) -> None:  # fmt: skip
        self.stage = stage
        self.handlers = dict(handlers)
        self.socket = context.socket(zmq.DEALER)
        self.socket.setsockopt(zmq.IDENTITY, stage.encode())
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.connect(endpoint)
        self.errors: Counter[str] = Counter()

    def handle_pending(self) -> None:
        while True:
            try:
                frames = self.socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            reply = self.handle(frames)
            send_message(self.socket, reply)

    def handle(self, frames: list[bytes]) -> Message:
        try:
            command = parse_command(frames)
            handler = self.handlers.get(command.type)
            if handler is None:
                raise CommandError("unsupported", f"{self.stage} does not handle {command.type}",
                                   seq=command.seq, command=command.type)  # fmt: skip
            try:
                result = handler(command.body)
            except CommandError as exc:
                exc.seq, exc.command = command.seq, command.type
                raise
            return make_ack(command, result, source=self.stage)
        except CommandError as exc:
            self.errors[exc.reason] += 1
            return make_error_ack(exc, source=self.stage)
        except Exception as exc:  # a bug in a handler must not stop the stage
            log.exception("%s: command handler failed", self.stage)
            self.errors["internal"] += 1
            return make_error_ack(CommandError("internal", repr(exc)), source=self.stage)

    def close(self) -> None:
        self.socket.close(linger=0)


def send_message(socket: zmq.Socket[bytes], message: Message) -> bool:
    """Send without blocking; returns False when the message had to be dropped."""
    try:
        socket.send_multipart(serialize(message), zmq.NOBLOCK)
    except zmq.Again:
        return False
    except ValueError:  # e.g. a NaN slipped into a header: a bug to log, not a crash
        log.exception("could not serialise a %s message", message.type)
        return False
    return True


class ParticipantBus:
    """XSUB/XPUB forwarder: any number of capture receivers in, any number of consumers out
    (behaviour stage, recorder, benchmarks), subscriptions forwarded upstream."""

    name = "bus"

    def __init__(self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints) -> None:
        self.context, self.endpoints = context, endpoints
        self.forwarded = 0

    def run(self, stop: threading.Event) -> None:
        inbound = self.context.socket(zmq.XSUB)
        outbound = self.context.socket(zmq.XPUB)
        for socket in (inbound, outbound):
            socket.setsockopt(zmq.LINGER, 0)
        inbound.bind(self.endpoints.capture)
        outbound.bind(self.endpoints.participant)
        poller = zmq.Poller()
        poller.register(inbound, zmq.POLLIN)
        poller.register(outbound, zmq.POLLIN)
        try:
            while not stop.is_set():
                events = dict(poller.poll(POLL_MS))
                if inbound in events:
                    self.forwarded += _forward(inbound, outbound)
                if outbound in events:
                    _forward(outbound, inbound)  # (un)subscriptions travel upstream
        finally:
            inbound.close(linger=0)
            outbound.close(linger=0)


def _forward(source: zmq.Socket[bytes], target: zmq.Socket[bytes], limit: int = 1000) -> int:
    for count in range(limit):
        try:
            frames = source.recv_multipart(zmq.NOBLOCK, copy=False)
        except zmq.Again:
            return count
        with contextlib.suppress(zmq.Again):  # a slow consumer: PUB semantics, drop
            target.send_multipart(frames, zmq.NOBLOCK, copy=False)
    return limit


def receive_messages(
    socket: zmq.Socket[bytes], errors: Counter[str], limit: int = 1000
) -> list[Message]:
    """Everything waiting on ``socket`` (up to ``limit``); malformed envelopes are counted
    by reason and dropped."""
    messages = []
    for _ in range(limit):
        try:
            frames = socket.recv_multipart(zmq.NOBLOCK)
        except zmq.Again:
            break
        try:
            messages.append(deserialize(frames))
        except EnvelopeError as exc:
            errors[exc.reason] += 1
    return messages


class RateMeter:
    """Events per second over the last reporting interval."""

    def __init__(self) -> None:
        self.count = 0
        self._since = time.monotonic()
        self._last_count = 0

    def rate(self, now: float) -> float:
        elapsed = now - self._since
        value = (self.count - self._last_count) / elapsed if elapsed > 0 else 0.0
        self._since, self._last_count = now, self.count
        return value
