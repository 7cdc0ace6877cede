"""Malformed capture input over real sockets: thousands of mutated Live Link Face datagrams
(UDP) and FaceCaptureX frames (TCP, in odd read sizes, across reconnects) never stop a
receiver and never raise inside it (no ``internal_error`` drop); each bad packet is counted
by its reason, and a good frame afterwards still arrives with the right values.

The decoders' own property tests live in tests/worker/ingest; this is the end-to-end
version an attacker on the booth network would run. Deterministic (a seeded generator).
"""

from __future__ import annotations

import functools
import random
import struct

import numpy as np
import pytest
import zmq

from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.wire import (
    build_facecapturex_frame,
    build_livelink_packet,
    livelink_values,
)
from tests.worker.face_subscriber import FaceSubscriber, face_sub, zmq_context
from tests.worker.ingest.test_receivers import (
    SMILE,
    SYNC_FRAME,
    not_sync,
    phone,
    smile,
    sync_livelink,
    tcp_receiver,
    udp_receiver,
)

__all__ = ["face_sub", "zmq_context"]

PACKETS = 3000
FRAMES = 1500
MARK = 0.75  # smile value of the frames that show the receiver has caught up


def marked(frame: FaceFrame) -> bool:
    return bool(frame.blendshapes[SMILE] == MARK)


SPECIALS = [b"nan", b"inf", b"-inf", b"1e999", b"", b"::", b"~", b"a", b"z", b"\x00", b"\xff"]


def mutate_bytes(rng: random.Random, packet: bytes) -> bytes:
    data = bytearray(packet)
    kind = rng.randrange(6)
    if kind == 0:  # flip a few bytes
        for _ in range(rng.randint(1, 8)):
            data[rng.randrange(len(data))] = rng.randrange(256)
    elif kind == 1:  # truncate
        del data[rng.randrange(len(data)) :]
    elif kind == 2:  # a float replaced by NaN, infinity or a huge value
        at = rng.randrange(max(1, len(data) - 4))
        data[at : at + 4] = struct.pack(">f", rng.choice([float("nan"), float("inf"), 3e38]))
    elif kind == 3:  # a length field made absurd
        at = rng.randrange(min(len(data), 40))
        data[at : at + 4] = struct.pack(">i", rng.choice([-1, 2**31 - 1, 70_000]))
    elif kind == 4:  # garbage appended or prepended
        noise = rng.randbytes(rng.randint(1, 300))
        data = bytearray(noise + data if rng.random() < 0.5 else data + noise)
    else:  # pure noise
        data = bytearray(rng.randbytes(rng.randint(0, 1500)))
    return bytes(data)


def mutate_text(rng: random.Random, frame: bytes) -> bytes:
    fields = frame[:-1].split(b"~")  # without the terminating 'a'
    for _ in range(rng.randint(1, 4)):
        at = rng.randrange(len(fields))
        kind = rng.randrange(4)
        if kind == 0:
            numbers = fields[at].split(b":")
            numbers[rng.randrange(len(numbers))] = rng.choice(SPECIALS)
            fields[at] = b":".join(numbers)
        elif kind == 1:
            del fields[at]
            if not fields:
                fields = [b""]
        elif kind == 2:
            fields.insert(at, rng.randbytes(rng.randint(0, 40)))
        else:
            fields[at] = fields[at] * rng.randint(2, 5)
    return b"~".join(fields) + b"a"


def test_livelink_survives_thousands_of_mutated_datagrams(
    zmq_context: zmq.Context[zmq.Socket[bytes]], face_sub: FaceSubscriber
) -> None:
    rng = random.Random(15)
    valid = build_livelink_packet(livelink_values(smile(0.25)))
    with udp_receiver(zmq_context, face_sub) as (receiver, send):
        sync_livelink(face_sub, send)
        for number in range(PACKETS):
            send(mutate_bytes(rng, valid))
            if number % 100 == 99:  # let the receiver catch up: UDP would drop the excess
                marker = build_livelink_packet(livelink_values(smile(MARK)), frame_number=number)
                face_sub.receive(
                    1,
                    send=functools.partial(send, marker),
                    accept=marked,
                    timeout=60,
                )
        good = build_livelink_packet(livelink_values(smile(0.625)))
        [frame] = face_sub.receive(
            1, send=lambda: send(good), accept=lambda f: f.blendshapes[SMILE] == 0.625, timeout=60
        )
        stats = receiver.stats.snapshot()
        assert receiver.running
    assert frame.blendshapes[SMILE] == pytest.approx(0.625)
    assert "internal_error" not in stats["drops"]
    # Many mutations stay valid (a flipped value byte, trailing bytes).
    assert sum(stats["drops"].values()) >= PACKETS // 6, stats["drops"]


def test_facecapturex_survives_thousands_of_mutated_frames(
    zmq_context: zmq.Context[zmq.Socket[bytes]], face_sub: FaceSubscriber
) -> None:
    rng = random.Random(15)
    valid = build_facecapturex_frame(smile(0.25), (10.0, 0.0, 0.0))
    with tcp_receiver(zmq_context, face_sub, max_frame_bytes=20_000) as receiver:
        sent = 0
        while sent < FRAMES:
            with phone(receiver.port) as client:  # a reconnect every few hundred frames
                face_sub.receive(1, send=lambda: client.sendall(SYNC_FRAME), timeout=60)
                batch = min(FRAMES - sent, rng.randint(200, 500))
                stream = b"".join(mutate_text(rng, valid) for _ in range(batch))
                at = 0
                while at < len(stream):  # odd read sizes
                    step = rng.randint(1, 4000)
                    client.sendall(stream[at : at + step])
                    at += step
                sent += batch
                # The receiver has read the whole batch once a marker after it arrives (a
                # marker glued to an unfinished mutated frame is dropped; it is resent).
                marker = build_facecapturex_frame(smile(MARK), (float(sent % 90), 0.0, 0.0))
                face_sub.receive(
                    1,
                    send=lambda: client.sendall(marker),  # noqa: B023
                    accept=lambda f: marked(f) and abs(f.head[0] - sent % 90) < 1e-3,  # noqa: B023
                    timeout=60,
                )
        good = build_facecapturex_frame(smile(0.625), (-20.0, 0.0, 0.0))
        with phone(receiver.port) as client:
            [frame] = face_sub.receive(
                1,
                send=lambda: client.sendall(good),
                accept=lambda f: not_sync(f) and f.blendshapes[SMILE] == 0.625,
                timeout=60,
            )
        stats = receiver.stats.snapshot()
        assert receiver.running
    np.testing.assert_allclose(frame.head[0], -20.0, atol=1e-3)
    assert "internal_error" not in stats["drops"]
    assert sum(stats["drops"].values()) >= 100, stats["drops"]  # merged frames count once
