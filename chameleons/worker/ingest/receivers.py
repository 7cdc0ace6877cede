"""Capture receivers: Live Link Face (UDP) and FaceCaptureX (TCP server) -> ZeroMQ PUB.

Each receiver runs one thread: it parses what arrives, normalises it (clock alignment,
:class:`FrameTransform`) and publishes the frames as envelopes (:func:`frame_message`) on a
PUB socket, topic ``face.participant``. A bad packet is counted in :class:`CaptureStats`
under its reason and dropped; nothing a sender does stops the loop.

By default the PUB socket *connects* to ``publish_endpoint`` (the consumer's SUB binds), so
several receivers can feed one consumer; ``bind_publisher=True`` binds it instead.
``port=0`` binds a free port; read it from ``.port`` after :meth:`start`.

With a :class:`SenderLock` (``pairing=``), input from any other address than the paired
phone is dropped and counted there (see :mod:`.pairing`).

The sender's clock is trusted only while it behaves (:class:`TimecodeGuard`: a frozen,
jumping or drifting timecode falls back to the arrival time, and the stats say why), and
Live Link frames, which UDP may deliver out of order, are put back in capture order within
:data:`REORDER_WINDOW_S` before they are published (:class:`ReorderBuffer`).
"""

from __future__ import annotations

import contextlib
import functools
import logging
import selectors
import socket
import threading
import time
from collections.abc import Callable
from types import TracebackType
from typing import Any, Self

import zmq

from chameleons.worker.envelope import frame_message, serialize
from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.errors import IngestError
from chameleons.worker.ingest.facecapturex import (
    DEFAULT_MAX_FRAME_BYTES,
    FaceCaptureXDecoder,
    parse_facecapturex_frame,
)
from chameleons.worker.ingest.livelink import (
    DEFAULT_ROTATION_FACTOR,
    METAHUMAN,
    NO_FACE,
    parse_livelink_packet,
)
from chameleons.worker.ingest.pairing import SenderLock
from chameleons.worker.ingest.stats import CaptureStats
from chameleons.worker.ingest.timecode import REORDER_WINDOW_S, ReorderBuffer, TimecodeGuard
from chameleons.worker.ingest.transform import FrameTransform

log = logging.getLogger(__name__)
PARTICIPANT_TOPIC = "face.participant"
_UDP_BUFFER = 65536
_BURST = 256  # datagrams handled per wake-up before checking for stop again
_TCP_READ = 65536


class FramePublisher:
    """A PUB socket that sends FaceFrames as envelopes. Use it from one thread only."""

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoint: str, *, bind: bool = False,
        topic: str = PARTICIPANT_TOPIC, source: str = "ingest",
    ) -> None:  # fmt: skip
        self.topic, self.source, self._seq = topic, source, 0
        self._socket = context.socket(zmq.PUB)
        self._socket.setsockopt(zmq.LINGER, 0)
        try:
            (self._socket.bind if bind else self._socket.connect)(endpoint)
        except zmq.ZMQError:
            self._socket.close()
            raise

    def publish(self, frame: FaceFrame) -> None:
        self._seq += 1
        message = frame_message(
            frame, self.topic, seq=self._seq, source=self.source, time=time.monotonic()
        )
        self._socket.send_multipart(serialize(message), copy=False)

    def close(self) -> None:
        self._socket.close(linger=0)


class _Receiver:
    """Shared thread, stop and publish machinery; subclasses own the capture sockets."""

    kind = "capture"
    reorder_window_s = 0.0  # a stream that may arrive out of order holds frames this long
    # Made by start(), owned by the receiver thread afterwards.
    _selector: selectors.BaseSelector
    _wake_r: socket.socket
    _wake_w: socket.socket

    def __init__(
        self, *, host: str, port: int, publish_endpoint: str,
        context: zmq.Context[zmq.Socket[bytes]] | None = None, bind_publisher: bool = False,
        transform: FrameTransform | None = None, topic: str = PARTICIPANT_TOPIC,
        align_clock: bool = True, clock: Callable[[], float] = time.monotonic,
        pairing: SenderLock | None = None,
    ) -> None:  # fmt: skip
        self.host, self.requested_port = host, port
        self.pairing = pairing
        self.port = 0
        self.transform = transform or FrameTransform()
        self.stats = CaptureStats(clock)
        self._clock = clock
        self._guard = TimecodeGuard() if align_clock else None
        window = self.reorder_window_s
        self._reorder = ReorderBuffer(window) if window > 0 else None
        self.stats.timecode = self._timecode
        self._publisher_args = (
            context or zmq.Context.instance(),
            publish_endpoint,
            bind_publisher,
            topic,
        )
        self._publisher: FramePublisher | None = None
        self._stopping = threading.Event()
        self._thread: threading.Thread | None = None
        self._logged: set[str] = set()

    # -- lifecycle ---------------------------------------------------------------------
    def start(self) -> Self:
        """Bind the capture socket and the publisher (errors surface here), then run."""
        if self._thread is not None:
            raise RuntimeError("receiver already started")
        context, endpoint, bind, topic = self._publisher_args
        self._publisher = FramePublisher(
            context, endpoint, bind=bind, topic=topic, source=f"ingest.{self.kind}"
        )
        self._selector = selectors.DefaultSelector()
        self._wake_r, self._wake_w = socket.socketpair()
        self._wake_r.setblocking(False)
        self._selector.register(self._wake_r, selectors.EVENT_READ, None)
        try:
            self._open()
        except OSError:
            self._release()
            raise
        self._thread = threading.Thread(target=self._run, name=f"ingest-{self.kind}", daemon=True)
        self._thread.start()
        return self

    def stop(self, timeout: float = 5.0) -> None:
        if self._thread is None:
            return
        self._stopping.set()
        with contextlib.suppress(OSError):  # closed already: the thread has ended
            self._wake_w.send(b"x")
        self._thread.join(timeout)
        if self._thread.is_alive():
            raise RuntimeError(f"{self.kind} receiver did not stop within {timeout} s")

    @property
    def running(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def __enter__(self) -> Self:
        return self.start()

    def __exit__(self, kind: type[BaseException] | None, exc: BaseException | None,
                 tb: TracebackType | None) -> None:  # fmt: skip
        self.stop()

    def _run(self) -> None:
        try:
            while not self._stopping.is_set():
                held = self._reorder.wait(self._clock()) if self._reorder is not None else None
                for key, _ in self._selector.select(held):
                    if key.data is not None:
                        self._guarded(key.data)
                if self._reorder is not None:
                    self._guarded(self._release_due)
        finally:
            self._close()
            self._release()

    def _release(self) -> None:
        self._selector.close()
        self._wake_r.close()
        self._wake_w.close()
        if self._publisher is not None:
            self._publisher.close()

    def _guarded(self, handler: Callable[[], None]) -> None:
        try:
            handler()
        except Exception:  # a bug must not end the capture; count it and carry on
            self.stats.count_drop("internal_error")
            if "internal_error" not in self._logged:
                self._logged.add("internal_error")
                log.exception("%s receiver: unexpected error (counted, carrying on)", self.kind)

    # -- frames ------------------------------------------------------------------------
    def _emit(self, frame: FaceFrame) -> None:
        # A frame without the sender's time (capture = receive) has nothing to check.
        if self._guard is not None and frame.capture_time != frame.receive_time:
            frame.capture_time = self._guard.capture_time(frame.capture_time, frame.receive_time)
        frame = self.transform.apply(frame)
        # The participant's own head turn (mirroring undone) for the booth check.
        yaw = -float(frame.head[0]) if self.transform.mirror else float(frame.head[0])
        self.stats.note_head(frame.receive_time, yaw, float(frame.head[1]))
        if self._reorder is None:
            self._publish(frame)
        elif not self._reorder.push(frame):
            self.stats.count_drop("late")  # after a later frame was published already

    def _release_due(self) -> None:
        assert self._reorder is not None
        for frame in self._reorder.due(self._clock()):
            self._publish(frame)

    def _publish(self, frame: FaceFrame) -> None:
        assert self._publisher is not None
        self._publisher.publish(frame)
        self.stats.count_frame(frame.receive_time)

    def _timecode(self) -> dict[str, Any]:
        """The sender's timecode as the guard judges it, and the reordering (any thread)."""
        guard = self._guard.snapshot() if self._guard is not None else {"trusted": None}
        reorder = self._reorder
        return {**guard, "reorder_window_ms": round(self.reorder_window_s * 1000),
                "reordered": reorder.reordered if reorder is not None else 0,
                "late": reorder.late if reorder is not None else 0}  # fmt: skip

    def _drop(self, error: IngestError) -> None:
        if error.reason == NO_FACE:  # the phone is fine, it sees nobody: not an error
            self.stats.count_no_face(self._clock())
            return
        if error.reason == METAHUMAN:  # the lab must change the app's mode: show why
            self.stats.set_problem(error.detail)
        self.stats.count_drop(error.reason)
        log.debug("%s receiver dropped input: %s", self.kind, error)

    # -- subclass hooks ------------------------------------------------------------------
    def _open(self) -> None:
        raise NotImplementedError

    def _close(self) -> None:
        raise NotImplementedError


class LiveLinkReceiver(_Receiver):
    """Live Link Face UDP packets (v6) on ``host:port``."""

    kind = "livelink"
    reorder_window_s = REORDER_WINDOW_S

    def __init__(self, *, rotation_factor: float = DEFAULT_ROTATION_FACTOR, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.rotation_factor = rotation_factor
        self._sock: socket.socket | None = None

    def _open(self) -> None:
        family = socket.AF_INET6 if ":" in self.host else socket.AF_INET
        sock = socket.socket(family, socket.SOCK_DGRAM)
        try:
            sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 1 << 20)  # ride out bursts
            sock.bind((self.host, self.requested_port))
        except OSError:
            sock.close()
            raise
        sock.setblocking(False)
        self._sock, self.port = sock, sock.getsockname()[1]
        self._selector.register(sock, selectors.EVENT_READ, self._read)

    def _read(self) -> None:
        assert self._sock is not None
        for _ in range(_BURST):
            try:
                data, sender = self._sock.recvfrom(_UDP_BUFFER)
            except BlockingIOError:
                return
            except OSError as exc:  # e.g. an ICMP error reported on the socket
                self._drop(IngestError("socket_error", str(exc)))
                return
            if self.pairing is not None and not self.pairing.admit(str(sender[0])):
                continue  # not the paired phone: counted by the lock
            self._guarded(functools.partial(self._packet, data))

    def _packet(self, data: bytes) -> None:
        try:
            frame = parse_livelink_packet(
                data, receive_time=self._clock(), rotation_factor=self.rotation_factor
            )
        except IngestError as exc:
            self._drop(exc)
            return
        self._emit(frame)

    def _close(self) -> None:
        if self._sock is not None:
            self._sock.close()


class FaceCaptureXReceiver(_Receiver):
    """FaceCaptureX TCP server on ``host:port``: one phone at a time, sends ``s`` after
    accepting; a newer connection replaces the current one (a phone that reconnects after a
    network drop must not wait behind its own dead connection)."""

    kind = "facecapturex"

    def __init__(self, *, max_frame_bytes: int = DEFAULT_MAX_FRAME_BYTES, **kwargs: Any) -> None:
        super().__init__(**kwargs)
        self.max_frame_bytes = max_frame_bytes
        self._listener: socket.socket | None = None
        self._client: socket.socket | None = None
        self._decoder = FaceCaptureXDecoder(max_frame_bytes)

    def _open(self) -> None:
        listener = socket.create_server((self.host, self.requested_port), backlog=4)
        listener.setblocking(False)
        self._listener, self.port = listener, listener.getsockname()[1]
        self._selector.register(listener, selectors.EVENT_READ, self._accept)

    def _accept(self) -> None:
        assert self._listener is not None
        try:
            client, sender = self._listener.accept()
        except (BlockingIOError, ConnectionAbortedError):
            return
        if self.pairing is not None and not self.pairing.admit(str(sender[0])):
            client.close()  # not the paired phone: counted by the lock
            return
        if self._client is not None:
            self.stats.count_drop("replaced_connection")
            self._disconnect()
        client.setblocking(False)
        with contextlib.suppress(OSError):
            client.send(b"s")  # the protocol's greeting; the app never reads it
        self._client, self._decoder = client, FaceCaptureXDecoder(self.max_frame_bytes)
        self._selector.register(client, selectors.EVENT_READ, self._read)
        self.stats.set_connected(True)

    def _read(self) -> None:
        assert self._client is not None
        try:
            data = self._client.recv(_TCP_READ)
        except BlockingIOError:
            return
        except ConnectionResetError:
            # The app never reads our "s", so its close often arrives as a reset: an end.
            data = b""
        except OSError as exc:
            self._drop(IngestError("socket_error", str(exc)))
            data = b""
        if not data:
            self._end_stream()
            return
        before = self._decoder.oversized
        frames = self._decoder.feed(data)
        if self._decoder.oversized > before:
            self.stats.count_drop("oversized", self._decoder.oversized - before)
        for raw in frames:
            self._guarded(functools.partial(self._frame, raw))
        if self._decoder.ended:
            self._disconnect()

    def _frame(self, raw: bytes) -> None:
        try:
            parsed = parse_facecapturex_frame(raw, receive_time=self._clock())
        except IngestError as exc:
            self._drop(exc)
            return
        if parsed.unknown_names or parsed.bad_fields:
            self.stats.count_unknown(len(parsed.unknown_names), parsed.bad_fields)
        self._emit(parsed.frame)

    def _end_stream(self) -> None:
        if self._decoder.pending_bytes:
            self.stats.count_drop("truncated")  # the connection ended inside a frame
        self._disconnect()

    def _disconnect(self) -> None:
        if self._client is None:
            return
        self._selector.unregister(self._client)
        self._client.close()
        self._client = None
        self.stats.set_connected(False)

    def _close(self) -> None:
        self._disconnect()
        if self._listener is not None:
            self._listener.close()
