"""A simulated phone: a plausible synthetic face, or a Live Link take, in the real wire formats.

:class:`SyntheticFace` is a deterministic function of time (given a seed): blinks every
2-6 s, a smooth head sway (degrees), smiles that come and go, talking bursts moving jaw and
mouth, brow raises, and a wandering gaze. :func:`run_simulation` paces frames at ``fps`` (or
at a take's own timecodes) and sends them as Live Link Face v6 UDP packets or FaceCaptureX
TCP text frames, built by :mod:`chameleons.worker.ingest.wire`.

:class:`CuedMoves` makes the simulated participant follow the booth check: the demo tells
the simulator each move the check asks for (``{"move": "turn", "seconds": 4}`` lines on its
standard input, ``simulate-face --follow-cues``), and the head holds still, turns left and
back, or nods within that time, its idle sway damped while the check runs.
"""

from __future__ import annotations

import json
import math
import socket
import threading
import time
from collections.abc import Callable, Iterable, Iterator
from dataclasses import dataclass, field, replace
from datetime import datetime
from typing import Literal, Protocol

import numpy as np

from chameleons.worker.frames import BLENDSHAPE_INDEX, N_BLENDSHAPES, F32Array
from chameleons.worker.ingest.livelink import DEFAULT_ROTATION_FACTOR
from chameleons.worker.ingest.wire import (
    FACECAPTUREX_END,
    build_facecapturex_frame,
    build_livelink_packet,
    format_mesh,
    livelink_values,
)
from chameleons.worker.takes import Take

Protocol_ = Literal["livelink", "facecapturex"]
MESH_VERTICES = 1220
_B = BLENDSHAPE_INDEX


@dataclass(frozen=True, slots=True)
class FaceSample:
    time: float  # seconds from the start of the simulation
    blendshapes: F32Array  # 52, canonical order
    head: F32Array  # yaw, pitch, roll in degrees
    eyes: F32Array  # left yaw/pitch/roll, right yaw/pitch/roll in degrees


def _bump(t: float, centre: float, width: float) -> float:
    """A smooth 0..1..0 pulse of total ``width`` around ``centre``."""
    x = (t - centre) / (width / 2)
    return 0.5 * (1 + math.cos(math.pi * x)) if abs(x) < 1 else 0.0


def _smooth_gate(x: float, low: float, high: float) -> float:
    u = min(1.0, max(0.0, (x - low) / (high - low)))
    return u * u * (3 - 2 * u)


@dataclass
class SyntheticFace:
    seed: int = 0
    _rngs: dict[int, np.random.Generator] = field(init=False, repr=False)
    _phases: np.ndarray = field(init=False, repr=False)
    _blinks: list[float] = field(init=False, repr=False)
    _brows: list[float] = field(init=False, repr=False)

    def __post_init__(self) -> None:
        # one generator per event stream, so a sample depends on t alone, not on call order
        self._phases = np.random.default_rng([self.seed, 0]).uniform(0, 2 * math.pi, 16)
        self._rngs = {
            1: np.random.default_rng([self.seed, 1]),
            2: np.random.default_rng([self.seed, 2]),
        }
        self._blinks = [float(self._rngs[1].uniform(0.5, 3.0))]
        self._brows = [float(self._rngs[2].uniform(2.0, 8.0))]

    def _events(self, times: list[float], t: float, low: float, high: float) -> list[float]:
        rng = self._rngs[1 if times is self._blinks else 2]
        while times[-1] < t + high:
            times.append(times[-1] + float(rng.uniform(low, high)))
        return times

    def sample(self, t: float) -> FaceSample:
        p = self._phases
        shapes = np.zeros(N_BLENDSHAPES, dtype=np.float32)
        blink = max((_bump(t, c, 0.18) for c in self._events(self._blinks, t, 2.0, 6.0)), default=0)
        talking = _smooth_gate(math.sin(2 * math.pi * t / 11.0 + p[0]), 0.1, 0.5)
        syllables = abs(math.sin(2 * math.pi * 2.3 * t + p[1])) * (
            0.6 + 0.4 * math.sin(2 * math.pi * 0.7 * t + p[2])
        )
        smile = 0.7 * _smooth_gate(math.sin(2 * math.pi * t / 17.0 + p[3]), 0.3, 0.9)
        brow = max((_bump(t, c, 0.9) for c in self._events(self._brows, t, 4.0, 10.0)), default=0)
        gaze_yaw = 8 * math.sin(2 * math.pi * 0.23 * t + p[4])
        gaze_pitch = 4 * math.sin(2 * math.pi * 0.17 * t + p[5])
        for side in ("Left", "Right"):
            shapes[_B["eyeBlink" + side]] = blink
            shapes[_B["eyeSquint" + side]] = 0.3 * smile
            shapes[_B["mouthSmile" + side]] = smile * (1.0 if side == "Left" else 0.9)
            shapes[_B["cheekSquint" + side]] = 0.4 * smile
            shapes[_B["browOuterUp" + side]] = 0.6 * brow
            shapes[_B["eyeLookUp" + side]] = max(0.0, gaze_pitch) / 20
            shapes[_B["eyeLookDown" + side]] = max(0.0, -gaze_pitch) / 20 + 0.3 * blink
        shapes[_B["browInnerUp"]] = 0.5 * brow + 0.1 * talking
        shapes[_B["jawOpen"]] = talking * (0.05 + 0.35 * syllables)
        shapes[_B["mouthFunnel"]] = talking * 0.2 * max(0.0, math.sin(2 * math.pi * 1.1 * t + p[6]))
        shapes[_B["mouthClose"]] = talking * 0.1 * (1 - syllables)
        shapes[_B["mouthLowerDownLeft"]] = shapes[_B["mouthLowerDownRight"]] = (
            talking * 0.3 * syllables
        )
        # gaze to the subject's left moves the left eye outwards and the right eye inwards
        shapes[_B["eyeLookOutLeft"]] = shapes[_B["eyeLookInRight"]] = max(0.0, gaze_yaw) / 25
        shapes[_B["eyeLookInLeft"]] = shapes[_B["eyeLookOutRight"]] = max(0.0, -gaze_yaw) / 25
        head = np.array(
            [
                10 * math.sin(2 * math.pi * 0.09 * t + p[7])
                + 3 * math.sin(2 * math.pi * 0.31 * t + p[8]),
                4 * math.sin(2 * math.pi * 0.13 * t + p[9])
                + 2.5 * talking * math.sin(2 * math.pi * 1.7 * t),
                3 * math.sin(2 * math.pi * 0.07 * t + p[10]),
            ],
            dtype=np.float32,
        )
        eyes = np.array([gaze_yaw, gaze_pitch, 0.0, gaze_yaw, gaze_pitch, 0.0], dtype=np.float32)
        return FaceSample(t, np.clip(shapes, 0, 1), head, eyes)

    def samples(self, fps: float, duration: float | None) -> Iterator[FaceSample]:
        i = 0
        while duration is None or i / fps < duration:
            yield self.sample(i / fps)
            i += 1


def take_samples(take: Take, duration: float | None) -> Iterator[FaceSample]:
    """A take's rows at their own times; looped until ``duration`` if given, else once."""
    period = take.duration + (float(np.median(np.diff(take.times))) if len(take) > 1 else 1 / 60)
    loop = 0
    while True:
        for i in range(len(take)):
            t = loop * period + float(take.times[i])
            if duration is not None and t >= duration:
                return
            yield FaceSample(t, take.blendshapes[i], take.head[i], take.eyes[i])
        loop += 1
        if duration is None:
            return


TURN_DEG, NOD_DEG = 40.0, 15.0  # a cued turn to the participant's left (yaw > 0), a nod
CHECK_SWAY = 0.15  # the idle head sway while the check runs (the participant holds still)
SWAY_RAMP_S = 0.3
MOVES = ("rest", "turn", "nod", "copy")


class CuedMoves:
    """The booth check's moves, cued as they are asked for (any thread), as head offsets on
    the clock the simulation runs on."""

    def __init__(self, clock: Callable[[], float] = time.monotonic) -> None:
        self.clock = clock
        self._lock = threading.Lock()
        self._moves: list[tuple[str, float, float]] = []  # (move, start, end) on ``clock``
        self.cued = 0
        self.refused = 0

    def cue(self, move: str, seconds: float, at: float | None = None) -> bool:
        """Start ``move`` now (or at ``at``) for ``seconds``; an unknown one is refused."""
        if move not in MOVES or not (isinstance(seconds, int | float) and 0 < seconds <= 60):
            self.refused += 1
            return False
        start = self.clock() if at is None else at
        with self._lock:
            self._moves = [m for m in self._moves if m[2] > start - 5.0] + [
                (move, start, start + float(seconds))]  # fmt: skip
            self.cued += 1
        return True

    def follow(self, lines: Iterable[str]) -> None:
        """Cue each JSON line ``{"move", "seconds"}`` (the simulator's standard input)."""
        for line in lines:
            try:
                cue = json.loads(line)
                self.cue(str(cue["move"]), float(cue["seconds"]))
            except (ValueError, KeyError, TypeError):
                self.refused += 1

    def head(self, now: float, sway: F32Array) -> F32Array:
        """The head at ``now``: the idle ``sway`` (damped while the check runs) plus the
        current move."""
        with self._lock:
            moves = list(self._moves)
        if not moves:
            return sway
        first, last = min(m[1] for m in moves), max(m[2] for m in moves)
        inside = min(now - first, last - now) / SWAY_RAMP_S
        damp = 1.0 - (1.0 - CHECK_SWAY) * min(1.0, max(0.0, inside))
        head = sway * np.float32(damp)
        for move, start, end in moves:
            if start <= now < end and move in ("turn", "nod"):
                # out and back within the middle 80 % of the time asked for
                u = (now - start) / (end - start)
                amount = math.sin(math.pi * min(1.0, max(0.0, (u - 0.1) / 0.8)))
                if move == "turn":
                    head[0] += TURN_DEG * amount
                else:
                    head[1] += NOD_DEG * amount
        return head


def cued_samples(samples: Iterator[FaceSample], moves: CuedMoves) -> Iterator[FaceSample]:
    """``samples`` with the cued moves on the head; sample times are mapped onto the moves'
    clock from when the first sample is taken (when :func:`run_simulation` starts)."""
    start: float | None = None
    for sample in samples:
        if start is None:
            start = moves.clock() - sample.time
        yield replace(sample, head=moves.head(start + sample.time, sample.head.copy()))


class FaceSender(Protocol):
    def send(self, sample: FaceSample) -> None: ...

    def close(self) -> None: ...


class LiveLinkSender:
    """UDP datagrams, frame numbers on a timecode clock (frames since local midnight)."""

    def __init__(self, host: str, port: int, *, fps: float = 60.0,
                 rotation_factor: float = DEFAULT_ROTATION_FACTOR,
                 source_host: str | None = None) -> None:  # fmt: skip
        self.address, self.rotation_factor = (host, port), rotation_factor
        self.rate = (round(fps), 1) if float(fps).is_integer() else (round(fps * 1000), 1000)
        now = datetime.now()
        self._start = (now - now.replace(hour=0, minute=0, second=0, microsecond=0)).total_seconds()
        family = socket.AF_INET6 if ":" in host else socket.AF_INET
        self._sock = socket.socket(family, socket.SOCK_DGRAM)
        if source_host is not None:  # send from this address (e.g. 127.0.0.2: another phone)
            self._sock.bind((source_host, 0))

    def send(self, sample: FaceSample) -> None:
        frames = (self._start + sample.time) * self.rate[0] / self.rate[1]
        values = livelink_values(
            sample.blendshapes, sample.head, sample.eyes, rotation_factor=self.rotation_factor
        )
        packet = build_livelink_packet(
            values, frame_number=int(frames), subframe=frames - int(frames), rate=self.rate,
            subject="simulated",
        )  # fmt: skip
        self._sock.sendto(packet, self.address)

    def close(self) -> None:
        self._sock.close()


class FaceCaptureXSender:
    """A TCP client like the app: connects, sends text frames, ends with ``z``."""

    def __init__(self, host: str, port: int, *, mesh: bool = True, timestamps: bool = False,
                 seed: int = 0, timeout: float = 5.0) -> None:  # fmt: skip
        self._sock = socket.create_connection((host, port), timeout=timeout)
        self._timestamps = timestamps
        rng = np.random.default_rng(seed)
        # a face-sized cloud of points; the receiver counts vertices but does not use them
        points = rng.normal(0, [0.05, 0.07, 0.03], (MESH_VERTICES, 3))
        self._mesh = format_mesh(points) if mesh else None  # formatting 3660 numbers is slow

    def send(self, sample: FaceSample) -> None:
        frame = build_facecapturex_frame(
            sample.blendshapes, tuple(float(a) for a in sample.head), mesh=self._mesh,
            timestamp=time.time() if self._timestamps else None,
        )  # fmt: skip
        self._sock.sendall(frame)

    def close(self) -> None:
        """Send ``z`` and close gracefully. The server's unread ``s`` greeting would turn a
        plain close into a reset, and a reset can discard the last frames still unread on
        the server: so half-close, read until the server closes too, then close."""
        try:
            self._sock.sendall(FACECAPTUREX_END)
            self._sock.shutdown(socket.SHUT_WR)
            self._sock.settimeout(2.0)
            while self._sock.recv(4096):
                pass
        except OSError:
            pass  # the server went away first, or is slow to close: nothing more to do
        finally:
            self._sock.close()


def open_sender(protocol: Protocol_, host: str, port: int, *, fps: float = 60.0,
                rotation_factor: float = DEFAULT_ROTATION_FACTOR, mesh: bool = True,
                seed: int = 0) -> FaceSender:  # fmt: skip
    if protocol == "livelink":
        return LiveLinkSender(host, port, fps=fps, rotation_factor=rotation_factor)
    if protocol == "facecapturex":
        return FaceCaptureXSender(host, port, mesh=mesh, seed=seed)
    raise ValueError(f"unknown protocol {protocol!r}")


def run_simulation(
    sender: FaceSender,
    samples: Iterator[FaceSample],
    *,
    stop: threading.Event | None = None,
    clock: Callable[[], float] = time.monotonic,
) -> int:
    """Send each sample at its time (absolute schedule, so no drift); returns frames sent.
    Returns early when ``stop`` is set. Closes the sender."""
    stop = stop or threading.Event()
    start, sent = clock(), 0
    try:
        for sample in samples:
            delay = start + sample.time - clock()
            if (delay > 0 and stop.wait(delay)) or stop.is_set():
                break
            sender.send(sample)
            sent += 1
    finally:
        sender.close()
    return sent
