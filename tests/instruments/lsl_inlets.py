"""Real LSL inlets for the tests: resolve a stream by name (waiting as long as discovery
takes, never a fixed sleep) and read what it sent. Not a test module."""

from __future__ import annotations

import time
from typing import Any

import pylsl

RESOLVE_TIMEOUT = 30.0


def resolve(name: str, timeout: float = RESOLVE_TIMEOUT) -> Any:
    """The stream called ``name``; resolution is asked again until ``timeout``."""
    deadline = time.monotonic() + timeout
    while time.monotonic() < deadline:
        found = pylsl.resolve_byprop("name", name, 1, min(5.0, deadline - time.monotonic()))
        if found:
            return found[0]
    raise AssertionError(f"no LSL stream {name!r} within {timeout} s")


def open_inlet(info: Any) -> Any:
    inlet = pylsl.StreamInlet(info, max_buflen=60, recover=False)
    inlet.open_stream(timeout=RESOLVE_TIMEOUT)
    return inlet


def labels(inlet: Any) -> list[str]:
    channel = inlet.info(timeout=RESOLVE_TIMEOUT).desc().child("channels").child("channel")
    names = []
    while not channel.empty():
        names.append(channel.child_value("label"))
        channel = channel.next_sibling()
    return names


def pull_until(inlet: Any, enough: int, timeout: float = 30.0) -> tuple[list[Any], list[float]]:
    """Samples and timestamps until ``enough`` arrived or ``timeout`` passed."""
    samples: list[Any] = []
    stamps: list[float] = []
    deadline = time.monotonic() + timeout
    while len(samples) < enough and time.monotonic() < deadline:
        chunk, times = inlet.pull_chunk(timeout=0.5)
        samples.extend(chunk)
        stamps.extend(times)
    return samples, stamps
