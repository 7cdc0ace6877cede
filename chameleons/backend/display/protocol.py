"""The robot display's WebSocket protocol (``/ws/display/<booth>``): JSON text frames.

Every frame is one JSON object with a ``type``. Angles are degrees, blendshapes 0..1 in the
canonical ARKit order of :data:`chameleons.worker.frames.BLENDSHAPE_NAMES`.

Server -> display
- ``{"type": "hello", "booth": str, "faces": [face ids], "blendshapes": [52 names]}``
  first, on every (re)connect; then the booth's current face and last frame, if any.
- ``{"type": "face", "seq": int, "t": float, "ts": float, "bs": [52 floats],
  "head": [yaw, pitch, roll] | absent, "eyes": [6 floats] | absent}`` face parameters
  (about 25 Hz). ``t`` is the sender's (worker's) monotonic clock in ms: the page spaces
  frames by it, not by their arrival, so bunched arrivals still play smoothly. ``ts`` is
  the server's wall clock in ms when it relayed the frame.
- ``{"type": "head", "seq": int, "t": float, "ts": float, "head": [yaw, pitch, roll]}``
  head pose (up to the worker's tick rate). Yaw > 0 turns the face towards the viewer's
  right, pitch > 0 tilts it down, roll > 0 tilts it counter-clockwise as the viewer sees it.
- ``{"type": "set_face", "face": "face-1" | "face-2" | "face-3" | "face-4",
  "renderer": "2d" | "3d" (optional: the study's condition chose the face's renderer)}``.
- ``{"type": "play_audio", "play_id": str, "prompt_id": str | null, "url": str,
  "lipsync_url": str | null}``: play the audio now. With ``lipsync_url`` the page drives
  mouth and jaw from those curves on the audio element's own clock (exact sync whatever
  the network delay); without, the worker's face frames carry the mouth.
- ``{"type": "stop_audio", "play_id": str | null}``: stop (any) playback.
- ``{"type": "pong", "id": int, "t": float, "server_ts": float}``: answer to a ping.

Display -> server
- ``{"type": "speech", "event": "start" | "end", "play_id": str, "prompt_id": str | null,
  "reason": "ended" | "stopped" | "interrupted" | "error" | "autoplay_blocked"
  (end only), "audio_delay_ms": float (start only: play command -> first sound)}``;
  the server forwards start/end to the worker (``speech_event`` command).
- ``{"type": "telemetry", "fps": float, "frames_in": float (frames/s received),
  "paint_latency_ms": {"p50", "p95", "max"}, "interp_delay_ms": float,
  "relay_to_paint_ms": float | null, "speaking": bool, "face": str, "renderer": "2d" | "3d",
  "frame_ms": {"p50", "p95"} (time to paint one frame, on the page's thread; WebGL's own
  rasterisation runs after it), "interval_ms": {"p50", "p95"} (between painted frames),
  "dropped_frames": int (refreshes missed in the last second), "head_missing": [ARKit
  names a lab's own head lacks] (3D with a lab's head only), "renderer_note": str (why a
  wanted 3D head is not shown)}`` once a second.
  Paint latency runs from a frame's arrival at the page to the first paint that shows it
  fully (this includes the interpolation delay that keeps motion smooth).
- ``{"type": "ping", "id": int, "t": float}``: clock-offset probe (``t`` is the page's
  ``performance.now()``).

Unknown types and malformed frames from the display are counted and ignored.
"""

from __future__ import annotations

import json
import math
import time
from collections.abc import Sequence
from typing import Any, Final

from chameleons.worker.frames import BLENDSHAPE_NAMES, N_BLENDSHAPES

FACE_IDS: Final = ("face-1", "face-2", "face-3", "face-4")
RENDERERS: Final = ("2d", "3d")
SPEECH_EVENTS: Final = frozenset({"start", "end"})
END_REASONS: Final = frozenset({"ended", "stopped", "interrupted", "error", "autoplay_blocked"})
INBOUND_TYPES: Final = frozenset({"speech", "telemetry", "ping"})
MAX_INBOUND_BYTES: Final = 8192
# Frames are dropped before control messages when a slow display falls behind.
DROPPABLE_TYPES: Final = frozenset({"face", "head"})

Message = dict[str, Any]


class ProtocolError(ValueError):
    """A frame from the display that is not part of the protocol; ``reason`` is a counter key."""

    def __init__(self, reason: str) -> None:
        super().__init__(reason)
        self.reason = reason


def _floats(values: Sequence[float], size: int, what: str, digits: int) -> list[float]:
    if len(values) != size:
        raise ValueError(f"{what} needs {size} values, got {len(values)}")
    out = [round(float(v), digits) for v in values]
    if not all(math.isfinite(v) for v in out):
        raise ValueError(f"{what} has non-finite values")
    return out


def now_ms() -> float:
    return round(time.time() * 1000.0, 1)


def _sender_ms(sent: float | None) -> float:
    """The sender's monotonic time (seconds) in ms; default: this process, now."""
    return round((time.monotonic() if sent is None else sent) * 1000.0, 2)


def face_message(
    blendshapes: Sequence[float],
    head: Sequence[float] | None = None,
    eyes: Sequence[float] | None = None,
    *,
    seq: int = 0,
    sent: float | None = None,
) -> Message:
    shapes = [min(1.0, max(0.0, v)) for v in _floats(blendshapes, N_BLENDSHAPES, "bs", 4)]
    message: Message = {"type": "face", "seq": seq, "t": _sender_ms(sent), "ts": now_ms(),
                        "bs": shapes}  # fmt: skip
    if head is not None:
        message["head"] = _floats(head, 3, "head", 3)
    if eyes is not None:
        message["eyes"] = _floats(eyes, 6, "eyes", 3)
    return message


def head_message(head: Sequence[float], *, seq: int = 0, sent: float | None = None) -> Message:
    return {"type": "head", "seq": seq, "t": _sender_ms(sent), "ts": now_ms(),
            "head": _floats(head, 3, "head", 3)}  # fmt: skip


def set_face_message(face: str, renderer: str | None = None) -> Message:
    if face not in FACE_IDS:
        raise ValueError(f"unknown face {face!r}; expected one of {', '.join(FACE_IDS)}")
    if renderer is not None and renderer not in RENDERERS:
        raise ValueError(f"unknown renderer {renderer!r}; expected 2d or 3d")
    message: Message = {"type": "set_face", "face": face}
    if renderer is not None:
        message["renderer"] = renderer
    return message


def play_audio_message(
    play_id: str, url: str, *, prompt_id: str | None = None, lipsync_url: str | None = None
) -> Message:
    return {"type": "play_audio", "play_id": play_id, "prompt_id": prompt_id, "url": url,
            "lipsync_url": lipsync_url}  # fmt: skip


def stop_audio_message(play_id: str | None = None) -> Message:
    return {"type": "stop_audio", "play_id": play_id}


def hello_message(booth: str) -> Message:
    return {"type": "hello", "booth": booth, "faces": list(FACE_IDS),
            "blendshapes": list(BLENDSHAPE_NAMES)}  # fmt: skip


def pong_message(ping: Message) -> Message:
    return {"type": "pong", "id": ping.get("id"), "t": ping.get("t"), "server_ts": now_ms()}


def parse_inbound(text: str) -> Message:
    """Validate one frame from the display; raises :class:`ProtocolError`."""
    if len(text) > MAX_INBOUND_BYTES:
        raise ProtocolError("too_large")
    try:
        message = json.loads(text, parse_constant=_reject_constant)
    except (ValueError, RecursionError) as exc:  # RecursionError: nested past the parser
        raise ProtocolError("bad_json") from exc
    if not isinstance(message, dict) or message.get("type") not in INBOUND_TYPES:
        raise ProtocolError("unknown_type")
    if message["type"] == "speech":
        _check_speech(message)
    return message


def _check_speech(message: Message) -> None:
    event = message.get("event")
    if event not in SPEECH_EVENTS:
        raise ProtocolError("bad_speech_event")
    if not isinstance(message.get("play_id"), str):
        raise ProtocolError("bad_play_id")
    prompt = message.get("prompt_id")
    if prompt is not None and not isinstance(prompt, str):
        raise ProtocolError("bad_prompt_id")
    if event == "end" and message.get("reason", "ended") not in END_REASONS:
        raise ProtocolError("bad_end_reason")


def _reject_constant(name: str) -> float:
    raise ValueError(f"non-finite number {name}")
