"""Fixtures of the ingest tests: a ZeroMQ context and a bound face subscriber."""

from tests.worker.face_subscriber import face_sub, zmq_context

__all__ = ["face_sub", "zmq_context"]
