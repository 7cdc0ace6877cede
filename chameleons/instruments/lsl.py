"""Lab Streaming Layer (LSL) outlets of this system (docs/instruments.md).

Two kinds of stream, both off unless asked for:

- ``Face`` (worker, ``chameleons worker --lsl``): ``chameleons-<booth>-participant`` and
  ``chameleons-<booth>-robot``, 61 float32 channels in :class:`FaceFrame` vector order
  (52 ARKit blendshapes 0..1 with Live Link's PascalCase labels, then head yaw/pitch/roll
  and the eyes' yaw/pitch/roll in degrees), labelled in the stream description as
  LabRecorder and the XDF readers expect (``desc/channels/channel/label``).
- ``Markers`` (server, ``CHAMELEONS_LSL=1``): ``chameleons-<booth>-events``, one string
  sample per timeline event (:func:`marker_text`).

Timestamps are this host's clocks mapped onto LSL's (:class:`LslClock`): the worker's
frames carry ``time.monotonic()`` times, the server's events wall-clock times.
"""

from __future__ import annotations

import json
import time
from collections.abc import Mapping, Sequence
from typing import Any

from chameleons.arkit.blendshapes import BLENDSHAPE_NAMES, EYE_NAMES, HEAD_NAMES

FACE_TYPE = "Face"
MARKERS_TYPE = "Markers"
STREAMS = ("participant", "robot", "events")
FACE_LABELS: tuple[str, ...] = (
    *(name[0].upper() + name[1:] for name in BLENDSHAPE_NAMES), *HEAD_NAMES, *EYE_NAMES,
)  # fmt: skip
FACE_UNITS: tuple[str, ...] = (
    *("normalized" for _ in BLENDSHAPE_NAMES), *("degrees" for _ in (*HEAD_NAMES, *EYE_NAMES)),
)  # fmt: skip
# Payload keys whose values are free text someone typed (wizard notes, typed speech):
# their markers say that text was written, never what (LSL travels unencrypted on the LAN).
FREE_TEXT_KEYS = frozenset({"text", "note", "notes", "comment", "said", "typed"})
MARKER_VERSION = 1


def stream_name(booth: str, stream: str) -> str:
    """``chameleons-<booth>-<stream>`` (participant, robot, events)."""
    if stream not in STREAMS:
        raise ValueError(f"unknown LSL stream {stream!r}: one of {', '.join(STREAMS)}")
    return f"chameleons-{booth}-{stream}"


def require_pylsl() -> None:
    """Load pylsl (and the liblsl it bundles) now, or say in one sentence why not."""
    try:
        import pylsl

        pylsl.library_version()
    except (ImportError, RuntimeError, OSError) as exc:
        raise RuntimeError(
            "LSL is on (CHAMELEONS_LSL or --lsl) but liblsl cannot be loaded: reinstall the "
            f"pylsl package, which bundles it ({exc})."
        ) from exc


def local_clock() -> float:
    import pylsl

    return float(pylsl.local_clock())


class LslClock:
    """Maps ``time.monotonic()`` and ``time.time()`` onto LSL's ``local_clock()``.

    The offsets are measured as the tightest of a few back-to-back readings and measured
    again every ``refresh_s`` (the wall clock may be stepped by NTP; the monotonic clocks
    only drift apart very slowly)."""

    def __init__(self, refresh_s: float = 10.0) -> None:
        self.refresh_s = refresh_s
        self._monotonic_offset = 0.0
        self._wall_offset = 0.0
        self._measured_at = -float("inf")

    def _measure(self) -> None:
        best: tuple[float, float, float] | None = None
        for _ in range(5):
            before = time.monotonic()
            lsl = local_clock()
            wall = time.time()
            after = time.monotonic()
            if best is None or after - before < best[0]:
                best = (after - before, lsl - (before + after) / 2, lsl - wall)
        assert best is not None
        self._monotonic_offset, self._wall_offset = best[1], best[2]
        self._measured_at = time.monotonic()

    def _fresh(self) -> None:
        if time.monotonic() - self._measured_at > self.refresh_s:
            self._measure()

    def from_monotonic(self, t: float) -> float:
        self._fresh()
        return t + self._monotonic_offset

    def from_wall(self, t: float) -> float:
        self._fresh()
        return t + self._wall_offset


def face_outlet(booth: str, stream: str, nominal_rate: float, source_id: str) -> Any:
    """A ``Face`` outlet with the 61 channels labelled (a pylsl ``StreamOutlet``)."""
    import pylsl

    info = pylsl.StreamInfo(stream_name(booth, stream), FACE_TYPE, len(FACE_LABELS),
                            nominal_rate, pylsl.cf_float32, source_id)  # fmt: skip
    desc = info.desc()
    desc.append_child_value("manufacturer", "Mechanical Chameleons")
    desc.append_child_value("booth", booth)
    channels = desc.append_child("channels")
    for label, unit in zip(FACE_LABELS, FACE_UNITS, strict=True):
        channel = channels.append_child("channel")
        channel.append_child_value("label", label)
        channel.append_child_value("unit", unit)
        channel.append_child_value("type", "Face")
    return pylsl.StreamOutlet(info)


def markers_outlet(booth: str, source_id: str) -> Any:
    """The booth's ``Markers`` outlet: one string channel, irregular rate."""
    import pylsl

    info = pylsl.StreamInfo(stream_name(booth, "events"), MARKERS_TYPE, 1,
                            pylsl.IRREGULAR_RATE, pylsl.cf_string, source_id)  # fmt: skip
    desc = info.desc()
    desc.append_child_value("manufacturer", "Mechanical Chameleons")
    desc.append_child_value("booth", booth)
    desc.append_child_value("format", f"chameleons-marker-json/{MARKER_VERSION}")
    return pylsl.StreamOutlet(info)


def marker_text(event: Mapping[str, Any]) -> str:
    """One timeline event (``events.repository.to_dict``) as the marker's JSON string:
    ``{"v", "event_id", "kind", "session_id", "interaction_id", "source", "server_time",
    "payload"}`` with free-text values replaced by ``"<text>"``. The event id is what
    ``chameleons import-xdf`` matches on."""
    payload = event.get("payload") or {}
    return json.dumps({
        "v": MARKER_VERSION, "event_id": event["id"], "kind": event["kind"],
        "session_id": event.get("session_id"), "interaction_id": event.get("interaction_id"),
        "source": event.get("source"), "server_time": event.get("server_time"),
        "payload": _redacted(payload),
    }, separators=(",", ":"), sort_keys=True, default=str)  # fmt: skip


def _redacted(value: Any) -> Any:
    if isinstance(value, Mapping):
        return {str(k): ("<text>" if str(k) in FREE_TEXT_KEYS and isinstance(v, str) and v
                         else _redacted(v)) for k, v in value.items()}  # fmt: skip
    if isinstance(value, Sequence) and not isinstance(value, str | bytes):
        return [_redacted(v) for v in value]
    return value


def parse_marker(text: str) -> dict[str, Any] | None:
    """A marker this system sent, or None for anyone else's marker."""
    try:
        value = json.loads(text)
    except (ValueError, TypeError):
        return None
    if not isinstance(value, dict) or "event_id" not in value or "kind" not in value:
        return None
    try:
        value["event_id"] = int(value["event_id"])
    except (TypeError, ValueError):
        return None
    return value
