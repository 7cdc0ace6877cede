"""The command protocol between the server and a worker, shared by both sides.

Transport: the server binds a ROUTER (``worker_command_endpoint``) and a SUB
(``worker_telemetry_endpoint``); each worker connects a DEALER whose identity is its booth
id and a PUB. Every message is one envelope (:mod:`chameleons.worker.envelope`).

- server -> worker, topic ``command``: ``type`` is the command, ``seq`` is chosen by the
  server, ``body`` carries the fields listed in :data:`COMMAND_FIELDS`.
- worker -> server, topic ``ack``: type ``ack``, the command's ``seq``, body
  ``{"ok": true, "command": ..., "result": {...}}`` or
  ``{"ok": false, "command": ..., "error": <reason>, "detail": <text>}``. Every command
  gets exactly one ack; an envelope too broken to read is answered with ``seq`` -1.
- worker -> server, topic ``hello``: on connect and periodically, body
  ``{"booth", "instance", "pid", "driver", ...}``; a new ``instance`` means a restart.
- worker PUB -> server SUB: ``telemetry.<booth>`` (1 Hz heartbeat), ``event.<booth>``
  (speech start/end, robot state, recording...), ``display.<booth>`` (virtual robot).
"""

from __future__ import annotations

import itertools
import time
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any, Final

from chameleons.worker.envelope import EnvelopeError, Message, deserialize

COMMAND_TOPIC: Final = "command"
ACK_TOPIC: Final = "ack"
HELLO_TOPIC: Final = "hello"
ACK_TYPE: Final = "ack"
HELLO_TYPE: Final = "hello"

SET_BEHAVIOUR: Final = "set_behaviour"
PLAY_PROMPT: Final = "play_prompt"
STOP_PROMPT: Final = "stop_prompt"
SET_FACE: Final = "set_face"
DISPLAY_RENDERERS: Final = ("2d", "3d")  # set_face "renderer": the virtual display's face
# ... or "furhat": the booth's Furhat (a worker with --driver furhat or virtual+furhat).
FURHAT_RENDERER: Final = "furhat"
START_RECORDING: Final = "start_recording"
STOP_RECORDING: Final = "stop_recording"
STATUS: Final = "status"
SPEECH_EVENT: Final = "speech_event"
RETRY_ROBOT: Final = "retry_robot"  # try the robot again after a refused login
RESET_PAIRING: Final = "reset_pairing"  # the capture pairs with the next phone that sends
# The booth check: the copy-delay probe forgets what it saw (measures only from now on).
RESET_DELAY_PROBE: Final = "reset_delay_probe"
# The copied head's neutral pose (chameleons.worker.behaviours.neutral): without ``seconds``
# measured afresh over the next frames (a new participant), with it the mean of the last
# ``seconds`` (the booth check's "hold still").
RECENTRE_HEAD: Final = "recentre_head"
# The booth check: the resting head pose is the mean of the last ``rest_seconds``; the head's
# movement from now on is reported against it (the capture's ``head_range``).
MARK_HEAD_REST: Final = "mark_head_rest"
# The capture page's neutral-face step (chameleons.worker.ingest.browser): ``action`` start
# collects the features of the frames that follow, finish takes their medians.
CALIBRATE_WEBCAM: Final = "calibrate_webcam"
# Server -> worker, no ack: the capture page's frames (chameleons.worker.ingest.browser).
CAPTURE_TOPIC: Final = "capture"

_NUMBER = (int, float)
# command -> field -> (accepted types, required)
COMMAND_FIELDS: Final[dict[str, dict[str, tuple[tuple[type, ...], bool]]]] = {
    SET_BEHAVIOUR: {"name": ((str,), True), "params": ((dict,), False)},
    PLAY_PROMPT: {
        "prompt_id": ((str,), True),
        "audio_url": ((str,), True),
        "lipsync_path": ((str, type(None)), False),
        # Typed speech on a robot with its own TTS (a Furhat): the text, in ``voice`` (None:
        # the robot's current voice); ``audio_url`` is then empty.
        "text": ((str,), False),
        "voice": ((str, type(None)), False),
        # One play's own id: the worker's speech events for it carry it, so the server
        # credits a start or end to this play only (the same prompt may play twice).
        "play_id": ((str, type(None)), False),
    },
    STOP_PROMPT: {},
    # renderer: the virtual robot display's face, "2d" or "3d", or "furhat" (the booth's
    # Furhat, with driver virtual+furhat); a study condition may set it.
    SET_FACE: {"face_id": ((str,), True), "renderer": ((str, type(None)), False)},
    START_RECORDING: {"interaction_id": ((str, int), True), "directory": ((str,), True)},
    STOP_RECORDING: {"interaction_id": ((str, int), False)},
    STATUS: {},
    RETRY_ROBOT: {},
    RESET_PAIRING: {},
    RESET_DELAY_PROBE: {},
    RECENTRE_HEAD: {"seconds": (_NUMBER, False)},
    MARK_HEAD_REST: {"rest_seconds": (_NUMBER, True)},
    CALIBRATE_WEBCAM: {"action": ((str,), True)},
    SPEECH_EVENT: {"event": ((str,), True), "prompt_id": ((str, type(None)), False),
                   "play_id": ((str, type(None)), False), "time": (_NUMBER, False)},
}  # fmt: skip
SPEECH_EVENTS: Final = frozenset({"start", "end"})


def telemetry_topic(booth: str) -> str:
    return f"telemetry.{booth}"


def event_topic(booth: str) -> str:
    return f"event.{booth}"


def display_topic(booth: str) -> str:
    return f"display.{booth}"


class CommandError(ValueError):
    """A command that cannot be carried out; ``reason`` is a short counter key."""

    def __init__(self, reason: str, detail: str = "", *, seq: int = -1, command: str = "") -> None:
        super().__init__(f"{reason}: {detail}" if detail else reason)
        self.reason = reason
        self.detail = detail
        self.seq = seq
        self.command = command


@dataclass(frozen=True, slots=True)
class Command:
    type: str
    seq: int
    body: dict[str, Any] = field(default_factory=dict)
    payload: bytes = b""


@dataclass(frozen=True, slots=True)
class Ack:
    seq: int
    command: str
    ok: bool
    result: dict[str, Any] = field(default_factory=dict)
    error: str = ""
    detail: str = ""


def make_command(
    type: str, body: Mapping[str, Any] | None = None, *, seq: int, source: str = "server"
) -> Message:
    return Message(COMMAND_TOPIC, type, seq, source, time.monotonic(), dict(body or {}))


def parse_command(frames: list[bytes]) -> Command:
    """Validate a command envelope; raises :class:`CommandError` with the seq when known."""
    try:
        message = deserialize(frames)
    except EnvelopeError as exc:
        raise CommandError("malformed", str(exc)) from exc
    return validate_command(message)


def validate_command(message: Message) -> Command:
    seq, kind = message.seq, message.type
    if message.topic != COMMAND_TOPIC:
        raise CommandError("wrong_topic", repr(message.topic), seq=seq, command=kind)
    spec = COMMAND_FIELDS.get(kind)
    if spec is None:
        raise CommandError("unknown_command", repr(kind), seq=seq, command=kind)
    unknown = sorted(set(message.body) - set(spec))
    if unknown:
        raise CommandError("unknown_field", ", ".join(unknown), seq=seq, command=kind)
    for name, (types, required) in spec.items():
        if name not in message.body:
            if required:
                raise CommandError("missing_field", name, seq=seq, command=kind)
            continue
        value = message.body[name]
        if isinstance(value, bool) or not isinstance(value, types):
            raise CommandError("bad_field", f"{name} has type {type(value).__name__}",
                               seq=seq, command=kind)  # fmt: skip
    if kind == SPEECH_EVENT and message.body["event"] not in SPEECH_EVENTS:
        raise CommandError("bad_field", "event must be start or end", seq=seq, command=kind)
    return Command(kind, seq, dict(message.body), message.payload)


def make_ack(
    command: Command, result: Mapping[str, Any] | None = None, *, source: str = ""
) -> Message:
    body = {"ok": True, "command": command.type, "result": dict(result or {})}
    return Message(ACK_TOPIC, ACK_TYPE, command.seq, source, time.monotonic(), body)


def make_error_ack(error: CommandError, *, source: str = "") -> Message:
    body = {"ok": False, "command": error.command, "error": error.reason, "detail": error.detail}
    return Message(ACK_TOPIC, ACK_TYPE, error.seq, source, time.monotonic(), body)


def parse_ack(message: Message) -> Ack:
    body = message.body
    if message.type != ACK_TYPE or not isinstance(body.get("ok"), bool):
        raise CommandError("malformed_ack", repr(message.type), seq=message.seq)
    result = body.get("result", {})
    return Ack(
        seq=message.seq,
        command=str(body.get("command", "")),
        ok=body["ok"],
        result=result if isinstance(result, dict) else {},
        error=str(body.get("error", "")),
        detail=str(body.get("detail", "")),
    )


def make_hello(booth: str, info: Mapping[str, Any]) -> Message:
    body = {"booth": booth, **info}
    return Message(HELLO_TOPIC, HELLO_TYPE, 0, booth, time.monotonic(), body)


class SequenceCounter:
    """Thread-unsafe increasing sequence numbers for one sender."""

    def __init__(self, start: int = 1) -> None:
        self._counter = itertools.count(start)

    def next(self) -> int:
        return next(self._counter)
