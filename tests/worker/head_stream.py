"""A participant's head as the Live Link Face app streams it, with the faults a lab meets: a
phone mounted off-centre (a resting pose that is not zero), a timecode that freezes, jumps or
drifts, and network jitter that reorders datagrams. Packets are the app's exact format
(:func:`tests.worker.livelink_recording.pose_packet`), sent over real UDP on a schedule.
Not a test module."""

from __future__ import annotations

import math
import random
import socket
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

from tests.worker.livelink_recording import FPS, pose_packet

Timecode = Callable[[int], int]  # frame index -> the frame number the packet carries


def true_timecode(k: int) -> int:
    return k


def frozen_timecode(k: int) -> int:
    """A timecode source that stopped (e.g. a lost Tentacle Sync): one frame number."""
    return 0


def jumping_timecode(k: int) -> int:
    """A source that keeps jumping by seconds, back and forth, every 20 frames."""
    return k + [0, 150, -90, 240, 30][(k // 20) % 5]


def drifting_timecode(k: int) -> int:
    """A sender clock running 10 % slow against the arrival times."""
    return int(k * 0.9)


@dataclass(frozen=True)
class Pose:
    """The head over time: a resting pose plus a turn to the left and a nod."""

    rest_yaw: float = 0.0
    rest_pitch: float = 0.0
    turn_at: float | None = None  # seconds from the start; the turn lasts turn_s
    turn_deg: float = 30.0
    turn_s: float = 1.0
    nod_at: float | None = None
    nod_deg: float = 15.0
    nod_s: float = 1.0
    brow_at: float | None = None  # a brow raise (0..1) of brow_s seconds
    brow: float = 0.6
    brow_s: float = 1.0

    def at(self, t: float) -> tuple[float, float]:
        return (self.rest_yaw + _bump(t, self.turn_at, self.turn_s) * self.turn_deg,
                self.rest_pitch + _bump(t, self.nod_at, self.nod_s) * self.nod_deg)  # fmt: skip

    def brows(self, t: float) -> float:
        return _bump(t, self.brow_at, self.brow_s) * self.brow


def _bump(t: float, start: float | None, length: float) -> float:
    """0 -> 1 -> 0 over ``length`` seconds from ``start`` (a half sine)."""
    if start is None or not start <= t <= start + length:
        return 0.0
    return math.sin(math.pi * (t - start) / length)


@dataclass(frozen=True)
class Sent:
    start: float  # monotonic time of the stream's t = 0
    count: int
    # When each packet actually left (monotonic), by packet number: on a busy machine the
    # sender's sleeps overrun, and a copy on arrival times follows these, not the schedule.
    sent_at: dict[int, float] = field(default_factory=dict)

    def left_at(self, t: float) -> float:
        """When the packet captured at ``t`` s into the stream left (its schedule if unknown)."""
        return self.sent_at.get(round(t * FPS), self.start + t)


def stream(
    port: int, pose: Pose, seconds: float, *, timecode: Timecode = true_timecode,
    jitter_s: float = 0.0, seed: int = 1,
) -> Sent:  # fmt: skip
    """Send ``seconds`` of ``pose`` at 60 fps to ``port``: packet ``k`` leaves at ``k / 60``
    plus up to ``jitter_s`` of random network delay (so later packets may overtake it)."""
    rng = random.Random(seed)
    n = int(seconds * FPS)
    schedule = sorted((k / FPS + rng.uniform(0.0, jitter_s), k) for k in range(n))
    packets = {k: pose_packet(timecode(k), *pose.at(k / FPS)) for k in range(n)}
    sent_at: dict[int, float] = {}
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        start = time.monotonic()
        for when, k in schedule:
            delay = start + when - time.monotonic()
            if delay > 0:
                time.sleep(delay)
            sock.sendto(packets[k], ("127.0.0.1", port))
            sent_at[k] = time.monotonic()
    return Sent(start, n, sent_at)


def stream_after(
    port: int, pose: Pose, seconds: float, begin: Callable[[], bool], *,
    until: Callable[[], bool] | None = None, limit: float = 90.0,
) -> Sent:  # fmt: skip
    """Hold ``pose``'s resting pose until ``begin()`` is true (polled every frame), then send
    ``seconds`` of ``pose`` from that moment (``start``), then the resting pose again until
    ``until()`` is true (when given)."""
    address = ("127.0.0.1", port)
    with socket.socket(socket.AF_INET, socket.SOCK_DGRAM) as sock:
        t0, k = time.monotonic(), 0

        def rest_while(condition: Callable[[], bool]) -> None:
            nonlocal k
            while condition():
                assert time.monotonic() < t0 + limit, "the phone streamed for too long"
                sock.sendto(pose_packet(k, pose.rest_yaw, pose.rest_pitch), address)
                k += 1
                time.sleep(max(0.0, t0 + k / FPS - time.monotonic()))

        rest_while(lambda: not begin())
        start = time.monotonic()
        for j in range(int(seconds * FPS)):
            time.sleep(max(0.0, start + j / FPS - time.monotonic()))
            sock.sendto(pose_packet(k, *pose.at(j / FPS), brow=pose.brows(j / FPS)), address)
            k += 1
        t0 = start + seconds - k / FPS  # the rest goes on on the same 60 fps grid
        if until is not None:
            rest_while(lambda: not until())
    return Sent(start, k)


def rising_edge(times: Sequence[float], values: Sequence[float], level: float) -> float | None:
    """When ``values`` first rose through ``level`` (linear between samples), or None."""
    for i in range(1, len(values)):
        if values[i - 1] < level <= values[i]:
            w = (level - values[i - 1]) / (values[i] - values[i - 1])
            return times[i - 1] + w * (times[i] - times[i - 1])
    return None
