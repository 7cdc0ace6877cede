"""Fixtures of the worker tests: a ZeroMQ context and the server's end of a worker's control
link (:class:`ControlPeer`, real sockets on fresh inproc endpoints of that context)."""

from __future__ import annotations

from collections.abc import Iterator

import pytest
import zmq

from tests.worker.control_peer import ControlPeer
from tests.worker.face_subscriber import zmq_context

__all__ = ["server", "zmq_context"]


@pytest.fixture
def server(zmq_context: zmq.Context[zmq.Socket[bytes]]) -> Iterator[ControlPeer]:
    peer = ControlPeer(zmq_context)
    yield peer
    peer.close()
