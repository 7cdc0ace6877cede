"""The receivers on real sockets: UDP/TCP on 127.0.0.1 (free ports) -> ZeroMQ SUB."""

from __future__ import annotations

import contextlib
import math
import socket
import time
from collections.abc import Callable, Iterator

import numpy as np
import pytest
import zmq
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from chameleons.settings import Settings
from chameleons.worker.frames import BLENDSHAPE_INDEX, FaceFrame
from chameleons.worker.ingest.inputs import start_capture
from chameleons.worker.ingest.pairing import SenderLock
from chameleons.worker.ingest.receivers import FaceCaptureXReceiver, LiveLinkReceiver
from chameleons.worker.ingest.transform import FrameTransform
from chameleons.worker.ingest.wire import (
    build_facecapturex_frame,
    build_livelink_packet,
    livelink_values,
)
from tests.worker.face_subscriber import FaceSubscriber

HOST = "127.0.0.1"
SMILE = BLENDSHAPE_INDEX["mouthSmileLeft"]
SYNC = 0.875  # smile value of the frames sent only to get the subscription going


def smile(value: float = 0.5) -> np.ndarray:
    shapes = np.zeros(52, dtype=np.float32)
    shapes[SMILE] = value
    return shapes


def not_sync(frame: FaceFrame) -> bool:
    sides = frame.blendshapes[[SMILE, BLENDSHAPE_INDEX["mouthSmileRight"]]]  # either, if mirrored
    return SYNC not in sides.tolist()


@contextlib.contextmanager
def udp_receiver(
    ctx: zmq.Context[zmq.Socket[bytes]], sub: FaceSubscriber, **kwargs
) -> Iterator[tuple[LiveLinkReceiver, Callable[[bytes], object]]]:
    receiver = LiveLinkReceiver(
        host=HOST, port=0, publish_endpoint=sub.endpoint, context=ctx, **kwargs
    )
    receiver.start()
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        yield receiver, lambda data: sock.sendto(data, (HOST, receiver.port))
    finally:
        receiver.stop()
        sock.close()


def sync_livelink(sub: FaceSubscriber, send: Callable[[bytes], object]) -> None:
    packet = build_livelink_packet(livelink_values(smile(SYNC)))
    sub.receive(1, send=lambda: send(packet))


def test_livelink_frames_arrive_normalised_after_garbage(zmq_context, face_sub) -> None:
    transform = FrameTransform(mirror=True)
    with udp_receiver(zmq_context, face_sub, transform=transform) as (receiver, send):
        assert receiver.port > 0
        sync_livelink(face_sub, send)
        good = build_livelink_packet(livelink_values(smile(), (30.0, -10.0, 5.0)), frame_number=60)
        nan = bytearray(good)
        nan[-4:] = b"\x7f\xc0\x00\x00"
        for junk in [b"", b"\x06garbage", good[:100], b"\x05" + good[1:], good + b"\0" * 3000]:
            send(junk)
        send(bytes(nan))
        send(good)
        [frame] = face_sub.receive(1, accept=not_sync)
        stats = receiver.stats.snapshot()
    # mirrored: the subject's left smile becomes the right, yaw and roll change sign
    assert frame.blendshapes[BLENDSHAPE_INDEX["mouthSmileRight"]] == pytest.approx(0.5)
    assert frame.blendshapes[SMILE] == 0.0
    np.testing.assert_allclose(frame.head, [-30.0, -10.0, -5.0], atol=1e-4)
    assert frame.source == "livelink"
    assert frame.capture_time <= frame.receive_time <= time.monotonic()
    assert stats["drops"] == {
        "truncated": 2, "bad_length": 1, "wrong_version": 1, "oversized": 1, "non_finite": 1,
    }  # fmt: skip
    assert stats["frames"] >= 2


def test_capture_times_keep_the_sender_spacing_and_order_despite_arrival_jitter(
    zmq_context, face_sub
) -> None:
    """UDP delivered a later frame first: within the reorder window the frames are
    published in capture order with the sender's spacing; one later than the window is
    dropped and counted (``late``), never published out of order."""
    with udp_receiver(zmq_context, face_sub) as (receiver, send):
        sync_livelink(face_sub, send)
        values = livelink_values(smile(0.25))
        # a fresh timecode: the two frames before it were held up in the network (33 ms)
        start = time.monotonic()
        send(build_livelink_packet(values, frame_number=60_002))
        for i in range(2):
            send(build_livelink_packet(values, frame_number=60_000 + i))
        frames = face_sub.receive(3, accept=not_sync)
        time.sleep(2 * receiver.reorder_window_s)  # the three are out: the next is too late
        send(build_livelink_packet(values, frame_number=59_990))
        for i in range(3, 30):  # the rest at the app's rate (no earlier than real time)
            time.sleep(max(0.0, start + (i - 2) / 60 - time.monotonic()))
            send(build_livelink_packet(values, frame_number=60_000 + i))
        frames += face_sub.receive(27, accept=not_sync)
        stats = receiver.stats.snapshot()
    captures = np.array([f.capture_time for f in frames])
    # the offset may creep by 1 ms per second of clock drift over the burst's arrival span
    creep = 1e-3 * (frames[-1].receive_time - frames[0].receive_time) + 1e-6
    spacing = np.diff(captures)
    # The offset follows the least-delayed frame: when a loaded machine took longer to read
    # the first frame than a later one, the offset drops at that later frame, which then
    # lands exactly on its receive time (the only way the sender's spacing may shrink).
    for k in np.flatnonzero(np.abs(spacing - 1 / 60) > creep):
        later = frames[k + 1]
        assert spacing[k] < 1 / 60, (k, spacing)
        assert later.capture_time == pytest.approx(later.receive_time, abs=1e-9), (k, spacing)
    kept = np.abs(spacing - 1 / 60) <= creep
    assert kept.sum() >= len(spacing) // 2, spacing  # the spacing is the sender's, not arrival's
    assert all(f.capture_time <= f.receive_time for f in frames)
    timecode = stats["timecode"]
    assert (timecode["reordered"], timecode["late"], timecode["trusted"]) == (2, 1, True)
    assert stats["drops"] == {"late": 1}
    assert receiver.stats.input_fps > 0


def test_receiver_survives_fuzzed_datagrams(zmq_context, face_sub) -> None:
    with udp_receiver(zmq_context, face_sub) as (receiver, send):

        @settings(max_examples=150, deadline=None, suppress_health_check=list(HealthCheck))
        @given(st.binary(max_size=700))
        def fuzz(data: bytes) -> None:
            send(data)

        fuzz()
        good = build_livelink_packet(livelink_values(smile()))
        face_sub.receive(3, send=lambda: send(good), accept=not_sync)
        assert receiver.running
        assert receiver.stats.snapshot()["drops"].get("internal_error", 0) == 0
    assert not receiver.running


def test_stop_is_clean_and_frees_the_port(zmq_context, face_sub) -> None:
    with udp_receiver(zmq_context, face_sub) as (receiver, _):
        port = receiver.port
    assert not receiver.running
    again = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    again.bind((HOST, port))
    again.close()


def test_bind_errors_surface_on_start(zmq_context, face_sub) -> None:
    taken = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    taken.bind((HOST, 0))
    try:
        receiver = LiveLinkReceiver(
            host=HOST, port=taken.getsockname()[1], publish_endpoint=face_sub.endpoint,
            context=zmq_context,
        )  # fmt: skip
        with pytest.raises(OSError, match="in use"):
            receiver.start()
        receiver.stop()  # harmless after a failed start
    finally:
        taken.close()


# --- FaceCaptureX over TCP ----------------------------------------------------------------


@contextlib.contextmanager
def tcp_receiver(
    ctx: zmq.Context[zmq.Socket[bytes]], sub: FaceSubscriber, **kwargs
) -> Iterator[FaceCaptureXReceiver]:
    receiver = FaceCaptureXReceiver(
        host=HOST, port=0, publish_endpoint=sub.endpoint, context=ctx, **kwargs
    )
    receiver.start()
    try:
        yield receiver
    finally:
        receiver.stop()


@contextlib.contextmanager
def phone(port: int) -> Iterator[socket.socket]:
    client = socket.create_connection((HOST, port), timeout=5)
    try:
        assert client.recv(1) == b"s"  # the server greets after accept
        yield client
    finally:
        client.close()


SYNC_FRAME = build_facecapturex_frame(smile(SYNC))


def test_facecapturex_stream_with_garbage_split_reads_and_reconnects(zmq_context, face_sub) -> None:
    yaws = [0.0, 10.0, -20.0, 30.0]
    frames = [build_facecapturex_frame(smile(0.25), (y, 0.0, 0.0)) for y in yaws]
    with tcp_receiver(zmq_context, face_sub) as receiver:
        with phone(receiver.port) as client:
            face_sub.receive(1, send=lambda: client.sendall(SYNC_FRAME))
            # a garbage frame first, then real frames in awkward pieces
            stream = b"1:2:3~not:a:transform:0.5a" + b"".join(frames)
            for start in range(0, len(stream), 37):
                client.sendall(stream[start : start + 37])
            got = face_sub.receive(4, accept=not_sync)
            client.sendall(b"z")
            assert client.recv(1) == b""  # the server ends the connection after z
        with phone(receiver.port) as second:  # the next phone, in sequence
            second.sendall(frames[1])
            got += face_sub.receive(1, accept=not_sync)
        stats = receiver.stats.snapshot()
    np.testing.assert_allclose([f.head[0] for f in got], [*yaws, 10.0], atol=1e-3)
    assert all(f.source == "facecapturex" for f in got)
    assert stats["drops"] == {"bad_transform": 1}
    assert stats["connections"] == 2


def test_facecapturex_oversized_and_replaced_connection(zmq_context, face_sub) -> None:
    small = build_facecapturex_frame(smile(0.5), (5.0, 0.0, 0.0))
    huge = build_facecapturex_frame(smile(0.5), mesh=np.full((3000, 3), 0.125))
    assert len(huge) > 20_000
    receiving = tcp_receiver(zmq_context, face_sub, max_frame_bytes=20_000)
    with receiving as receiver, phone(receiver.port) as stale, phone(receiver.port) as fresh:
        stale.sendall(small[:50])  # half a frame from a phone that then went silent
        assert stale.recv(1) == b""  # replaced: the old connection is closed
        face_sub.receive(1, send=lambda: fresh.sendall(SYNC_FRAME))
        fresh.sendall(huge + small)
        [frame] = face_sub.receive(1, accept=not_sync)
        stats = receiver.stats.snapshot()
    assert frame.head[0] == pytest.approx(5.0, abs=1e-3)
    assert stats["drops"] == {"oversized": 1, "replaced_connection": 1}
    assert stats["connected"] is True
    assert stats["unknown_names"] == 0


def test_start_capture_from_settings_runs_both_inputs(zmq_context, face_sub) -> None:
    settings = Settings(mirror=False, livelink_rotation_scale="radians")
    inputs = start_capture(
        settings, publish_endpoint=face_sub.endpoint, context=zmq_context, host=HOST,
        livelink_port=0, facecapturex_port=0,
    )  # fmt: skip
    sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    try:
        packet = build_livelink_packet(livelink_values(smile(), (45.0, 0, 0), rotation_factor=1.0))
        [udp] = face_sub.receive(1, send=lambda: sock.sendto(packet, (HOST, inputs.livelink.port)))
        with phone(inputs.facecapturex.port) as client:
            client.sendall(build_facecapturex_frame(smile(), (-7.0, 0.0, 0.0)))
            [tcp] = face_sub.receive(1, accept=lambda f: f.source == "facecapturex")
        telemetry = inputs.telemetry()
    finally:
        inputs.stop()
        sock.close()
    assert udp.head[0] == pytest.approx(45.0 * 180 / math.pi, rel=1e-5)  # radians setting
    assert tcp.head[0] == pytest.approx(-7.0, abs=1e-3)
    assert telemetry["livelink"]["frames"] >= 1
    assert telemetry["facecapturex"]["frames"] == 1
    assert telemetry["facecapturex"]["port"] == inputs.facecapturex.port


@pytest.mark.skipif(not socket.has_ipv6, reason="no IPv6 on this host")
def test_livelink_over_ipv6_loopback(zmq_context, face_sub) -> None:
    try:
        probe = socket.socket(socket.AF_INET6, socket.SOCK_DGRAM)
        probe.bind(("::1", 0))
    except OSError:
        pytest.skip("IPv6 loopback not configured")
    receiver = LiveLinkReceiver(
        host="::1", port=0, publish_endpoint=face_sub.endpoint, context=zmq_context
    )
    receiver.start()
    try:
        packet = build_livelink_packet(livelink_values(smile()))
        [frame] = face_sub.receive(1, send=lambda: probe.sendto(packet, ("::1", receiver.port)))
    finally:
        receiver.stop()
        probe.close()
    assert frame.blendshapes[SMILE] == 0.5


def test_no_face_packets_are_counted_apart_and_a_metahuman_stream_names_the_fix(
    zmq_context, face_sub
) -> None:
    from tests.worker.ingest.test_livelink import metahuman_packet

    with udp_receiver(zmq_context, face_sub) as (receiver, send):
        sync_livelink(face_sub, send)
        full = build_livelink_packet(livelink_values(smile()))
        header_only = full[: len(full) - 1 - 4 * 61]  # the app's "no face" packet
        for _ in range(5):
            send(header_only)
        send(metahuman_packet())
        send(full)
        face_sub.receive(1, accept=not_sync)
        stats = receiver.stats.snapshot()
    assert stats["no_face"] == 5
    assert stats["no_face_recent"] is True
    assert "no_face" not in stats["drops"]  # not an error
    assert "truncated" not in stats["drops"]
    assert stats["drops"] == {"metahuman_stream": 1}
    assert "Live Link (ARKit)" in stats["problem"]


def test_facecapturex_accepts_only_the_paired_phone(zmq_context, face_sub) -> None:
    """A connection from another address than the paired phone is closed at once and
    counted; the paired phone's stream goes through (two real TCP clients, two addresses)."""
    lock = SenderLock()
    with (
        tcp_receiver(zmq_context, face_sub, pairing=lock) as receiver,
        socket.socket(socket.AF_INET, socket.SOCK_STREAM) as paired,
    ):
        paired.bind(("127.0.0.2", 0))
        paired.connect((HOST, receiver.port))
        assert paired.recv(1) == b"s"
        face_sub.receive(1, send=lambda: paired.sendall(SYNC_FRAME))
        with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as other:
            other.bind(("127.0.0.3", 0))
            other.settimeout(5)
            other.connect((HOST, receiver.port))
            assert other.recv(1) == b""  # closed without the greeting
        paired.sendall(build_facecapturex_frame(smile(0.25), (12.0, 0.0, 0.0)))
        [frame] = face_sub.receive(1, accept=not_sync)
    assert abs(abs(float(frame.head[0])) - 12.0) < 1e-3
    state = lock.snapshot()
    assert (state["sender"], state["other_packets"], state["last_other"]) == (
        "127.0.0.2", 1, "127.0.0.3",
    )  # fmt: skip
