"""The timecode guard's judgement on its own (frames at 60 fps on a simulated clock): what
is not a fault stays trusted (a pause, one jump, late frames), each fault is named, and the
timecode is trusted again after it behaved for ``recover_s``. The reorder buffer releases in
capture order after its window. (Through a real worker: tests/worker/test_timecode_faults.)"""

from __future__ import annotations

import pytest

from chameleons.worker.frames import FaceFrame
from chameleons.worker.ingest.timecode import (
    DRIFTING,
    FROZEN,
    JUMPING,
    ReorderBuffer,
    TimecodeGuard,
)

FPS = 60.0


def feed(guard: TimecodeGuard, frames: range, sender: float = 100.0, receive: float = 5.0,
         *, sender_rate: float = 1.0, delay: float = 0.002) -> float:  # fmt: skip
    """Frames ``k`` sent at ``sender + k / FPS * sender_rate`` (the sender's clock), arriving
    at ``receive + k / FPS + delay``; returns the last capture time."""
    capture = 0.0
    for k in frames:
        capture = guard.capture_time(sender + k / FPS * sender_rate, receive + k / FPS + delay)
    return capture


def test_a_good_timecode_is_trusted_and_keeps_the_sender_spacing() -> None:
    guard = TimecodeGuard()
    first = feed(guard, range(1))
    last = feed(guard, range(1, 120))
    assert guard.problem is None
    assert last - first == pytest.approx(119 / FPS, abs=1e-6)


def test_a_pause_in_the_stream_and_one_jump_are_not_faults() -> None:
    guard = TimecodeGuard()
    feed(guard, range(60))
    feed(guard, range(90, 150))  # half a second with no frames (the face left the view)
    feed(guard, range(150, 210), sender=5000.0)  # the app restarted: a new timecode, once
    assert (guard.problem, guard.jumps, guard.fallbacks) == (None, 1, 0)


def test_a_frozen_timecode_falls_back_to_arrival_time_then_recovers() -> None:
    guard = TimecodeGuard()
    feed(guard, range(60))
    for k in range(60, 120):  # the timecode stops while frames keep coming
        capture = guard.capture_time(100.0 + 59 / FPS, 5.0 + k / FPS)
    assert guard.problem == FROZEN
    assert capture == 5.0 + 119 / FPS  # the arrival time
    feed(guard, range(120, 120 + int(4 * FPS)), sender=200.0)  # good again: not yet trusted
    assert guard.problem is not None
    feed(guard, range(400, 400 + int(2 * FPS)), sender=200.0)
    assert guard.problem is None
    assert guard.fallbacks == 1


def test_a_timecode_that_keeps_jumping_is_named() -> None:
    guard = TimecodeGuard()
    for hop in range(4):
        feed(guard, range(hop * 20, hop * 20 + 20), sender=100.0 + 7 * hop)
    assert guard.problem == JUMPING


def test_a_slow_sender_clock_is_drifting() -> None:
    guard = TimecodeGuard()
    feed(guard, range(int(1.5 * FPS)), sender_rate=0.9)
    assert guard.problem is None  # 150 ms behind after 1.5 s: within the bound
    feed(guard, range(int(1.5 * FPS), int(4 * FPS)), sender_rate=0.9)
    assert guard.problem == DRIFTING  # the least lag of the last second beyond 250 ms


def test_late_frames_are_not_a_fault() -> None:
    guard = TimecodeGuard()
    for k in range(240):  # every fifth frame 40 ms late on the network
        guard.capture_time(100.0 + k / FPS, 5.0 + k / FPS + (0.040 if k % 5 == 0 else 0.002))
    assert guard.problem is None


def test_the_reorder_buffer_releases_in_capture_order_after_its_window() -> None:
    buffer = ReorderBuffer(0.05)
    for t in (1.000, 1.033, 1.017):
        assert buffer.push(FaceFrame(t, t + 0.04))
    assert buffer.due(1.04) == []  # the first is due at 1.05
    assert [f.capture_time for f in buffer.due(1.10)] == [1.000, 1.017, 1.033]
    assert buffer.reordered == 1
    assert not buffer.push(FaceFrame(1.020, 1.11))  # after 1.033 was released: too late
    assert (buffer.late, len(buffer), buffer.wait(2.0)) == (1, 0, None)
