"""A real ZeroMQ SUB that capture receivers publish to, for tests (not a test module)."""

from __future__ import annotations

import time
import uuid
from collections.abc import Callable, Iterator

import pytest
import zmq

from chameleons.worker.envelope import deserialize, message_frame
from chameleons.worker.frames import FaceFrame


class FaceSubscriber:
    """A SUB bound at an inproc endpoint that the receivers' PUB sockets connect to."""

    def __init__(self, context: zmq.Context[zmq.Socket[bytes]]) -> None:
        self.context = context
        self.endpoint = f"inproc://face-{uuid.uuid4().hex}"
        self.socket = context.socket(zmq.SUB)
        self.socket.setsockopt(zmq.LINGER, 0)
        self.socket.setsockopt(zmq.SUBSCRIBE, b"face.participant")
        self.socket.bind(self.endpoint)

    def receive(
        self,
        count: int,
        *,
        send: Callable[[], object] | None = None,
        accept: Callable[[FaceFrame], bool] = lambda frame: True,
        timeout: float = 5.0,
    ) -> list[FaceFrame]:
        """Poll until ``count`` accepted frames arrived, calling ``send`` between polls (a PUB
        drops what it sends before the subscription reaches it, so senders keep sending)."""
        frames: list[FaceFrame] = []
        deadline = time.monotonic() + timeout
        while len(frames) < count:
            if time.monotonic() > deadline:
                raise AssertionError(f"received {len(frames)} of {count} frames in {timeout} s")
            if send is not None:
                send()
            while self.socket.poll(20 if send else 100) and len(frames) < count:
                parts = self.socket.recv_multipart()
                assert parts[0] == b"face.participant"
                frame = message_frame(deserialize(parts))
                if accept(frame):
                    frames.append(frame)
        return frames

    def drain(self) -> int:
        n = 0
        while self.socket.poll(0):
            self.socket.recv_multipart()
            n += 1
        return n


@pytest.fixture
def zmq_context() -> Iterator[zmq.Context[zmq.Socket[bytes]]]:
    context: zmq.Context[zmq.Socket[bytes]] = zmq.Context()
    yield context
    context.term()


@pytest.fixture
def face_sub(zmq_context: zmq.Context[zmq.Socket[bytes]]) -> Iterator[FaceSubscriber]:
    subscriber = FaceSubscriber(zmq_context)
    yield subscriber
    subscriber.socket.close(linger=0)
