"""The server's end of the worker control link, kept minimal and synchronous for tests (the
real one is :class:`chameleons.backend.bridge.Bridge`). Not a test module."""

from __future__ import annotations

import itertools
import time
import uuid
from collections.abc import Callable
from typing import Any

import zmq

from chameleons.worker.control import Ack, make_command, parse_ack
from chameleons.worker.envelope import Message, deserialize, serialize


class ControlPeer:
    """A ROUTER and a SUB bound on fresh inproc endpoints of ``context``."""

    def __init__(self, context: zmq.Context[zmq.Socket[bytes]]) -> None:
        name = uuid.uuid4().hex[:8]
        self.command_endpoint = f"inproc://server-commands-{name}"
        self.telemetry_endpoint = f"inproc://server-telemetry-{name}"
        self.router = context.socket(zmq.ROUTER)
        self.router.setsockopt(zmq.ROUTER_HANDOVER, 1)
        self.router.bind(self.command_endpoint)
        self.sub = context.socket(zmq.SUB)
        self.sub.setsockopt(zmq.SUBSCRIBE, b"")
        self.sub.bind(self.telemetry_endpoint)
        self.hellos: list[Message] = []
        self.published: list[Message] = []
        self._seq = itertools.count(100)
        self._acks: dict[int, Ack] = {}

    def close(self) -> None:
        self.router.close(linger=0)
        self.sub.close(linger=0)

    def _pump(self, timeout_ms: int) -> None:
        poller = zmq.Poller()
        poller.register(self.router, zmq.POLLIN)
        poller.register(self.sub, zmq.POLLIN)
        events = dict(poller.poll(timeout_ms))
        if self.router in events:
            _identity, *frames = self.router.recv_multipart()
            message = deserialize(frames)
            if message.topic == "hello":
                self.hellos.append(message)
            else:
                ack = parse_ack(message)
                self._acks[ack.seq] = ack
        if self.sub in events:
            self.published.append(deserialize(self.sub.recv_multipart()))

    def wait(self, condition: Callable[[], Any], timeout: float = 5.0) -> Any:
        deadline = time.monotonic() + timeout
        while not (result := condition()):
            if time.monotonic() > deadline:
                raise AssertionError("control peer: condition not met in time")
            self._pump(20)
        return result

    def send_raw(self, booth: str, frames: list[bytes]) -> None:
        self.router.send_multipart([booth.encode(), *frames])

    def command(self, booth: str, kind: str, body: dict[str, Any] | None = None,
                timeout: float = 5.0) -> Ack:  # fmt: skip
        seq = next(self._seq)
        self.wait(lambda: any(h.body["booth"] == booth for h in self.hellos), timeout)
        self.send_raw(booth, serialize(make_command(kind, body or {}, seq=seq)))
        return self.ack(seq, timeout)

    def ack(self, seq: int, timeout: float = 5.0) -> Ack:
        ack: Ack = self.wait(lambda: self._acks.pop(seq, None), timeout)
        return ack

    def of_type(self, kind: str) -> list[Message]:
        return [m for m in self.published if m.type == kind]
