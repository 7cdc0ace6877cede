"""The worker's control hub: its one connection to the server, and the stages' switchboard.

- a DEALER (identity = booth id) connected to the server's ROUTER: commands in, acks out,
  ``hello`` on start and every ``hello_interval``;
- a PUB connected to the server's SUB: the 1 Hz heartbeat (``telemetry.<booth>``), events
  (``event.<booth>``) and the virtual robot's frames (``display.<booth>``);
- a ROUTER the stages connect to: each command goes to the stage that handles it
  (:data:`ROUTES`) and the stage's ack comes back through here;
- a SUB on the stages' PUBs for their ``stats.*``, ``event.*`` and ``display.*``.

A command that cannot be parsed, is unknown, or whose stage is not running is answered
with an error ack at once and counted; nothing a sender does stops the loop.
"""

from __future__ import annotations

import logging
import os
import threading
import time
import uuid
from collections import Counter
from collections.abc import Callable, Mapping
from dataclasses import dataclass, field
from typing import Any

import zmq

from chameleons import __version__
from chameleons.worker.control import (
    CAPTURE_TOPIC,
    PLAY_PROMPT,
    RECENTRE_HEAD,
    RESET_DELAY_PROBE,
    RETRY_ROBOT,
    SET_BEHAVIOUR,
    SET_FACE,
    SPEECH_EVENT,
    START_RECORDING,
    STATUS,
    STOP_PROMPT,
    STOP_RECORDING,
    Command,
    CommandError,
    event_topic,
    make_ack,
    make_error_ack,
    make_hello,
    parse_command,
    telemetry_topic,
)
from chameleons.worker.curve import ClientKeys, apply_client
from chameleons.worker.envelope import EnvelopeError, Message, deserialize
from chameleons.worker.stage import (
    DISPLAY_PREFIX,
    EVENT_PREFIX,
    FINAL_LINGER_MS,
    POLL_MS,
    STATS_PREFIX,
    Endpoints,
    receive_messages,
    send_message,
)

log = logging.getLogger(__name__)
ROUTES: dict[str, str] = {
    SET_BEHAVIOUR: "behaviour", PLAY_PROMPT: "playback", STOP_PROMPT: "playback",
    SET_FACE: "playback", SPEECH_EVENT: "playback", START_RECORDING: "recorder",
    STOP_RECORDING: "recorder", RETRY_ROBOT: "playback", RESET_DELAY_PROBE: "recorder",
    RECENTRE_HEAD: "behaviour",
}  # fmt: skip
ROBOT_FACE_FIELDS = ("face_id", "robot_face_id", "unmapped_face", "refused")
ROBOT_OUTPUT_FIELDS = ("state", "problem", "retry_in")  # per robot of a two-robot booth
StatsSource = Callable[[], Mapping[str, Any]]
LocalHandler = Callable[[Mapping[str, Any]], Mapping[str, Any]]  # body -> result
CaptureSink = Callable[[Message], None]  # the capture page's relayed frames (no ack)
_CAPTURE = CAPTURE_TOPIC.encode()
STAGE_WAIT = 2.0  # seconds a command waits for its stage to connect
RETRY_INTERVAL = 0.01
FINAL_DRAIN_MS = 100  # the hub's last reads: until the stages' sockets are quiet this long
FINAL_DRAIN_LIMIT = 2.0  # ... or this many seconds (a stage that did not stop keeps talking)


@dataclass(frozen=True, slots=True)
class HubConfig:
    booth: str
    command_endpoint: str
    telemetry_endpoint: str
    hello_interval: float = 2.0
    heartbeat_interval: float = 1.0
    info: Mapping[str, Any] = field(default_factory=dict)  # driver, ports... for hello
    curve: ClientKeys | None = None  # CURVE keys of the link to the server (None: plain)


class ControlHub:
    name = "hub"

    def __init__(
        self, context: zmq.Context[zmq.Socket[bytes]], endpoints: Endpoints, config: HubConfig,
        *, ingest_stats: StatsSource | None = None,
        local: Mapping[str, LocalHandler] | None = None, capture: CaptureSink | None = None,
    ) -> None:  # fmt: skip
        self.context, self.endpoints, self.config = context, endpoints, config
        # Commands the hub answers itself (the capture receivers are not a stage).
        self.local: dict[str, LocalHandler] = dict(local or {})
        self.capture = capture
        self.instance = uuid.uuid4().hex[:12]
        self.started = time.monotonic()
        self.ingest_stats = ingest_stats
        self.latest: dict[str, tuple[float, dict[str, Any]]] = {}
        self.errors: Counter[str] = Counter()
        self.commands: Counter[str] = Counter()
        self._heartbeats = 0
        self._waiting: list[tuple[float, Command, list[bytes]]] = []

    def run(self, stop: threading.Event) -> None:
        sockets = self._open()
        server, uplink, stages, sub = sockets
        poller = zmq.Poller()
        for socket in (server, stages, sub):
            poller.register(socket, zmq.POLLIN)
        now = time.monotonic()
        next_hello, next_beat = now, now + self.config.heartbeat_interval
        try:
            while not stop.is_set():
                now = time.monotonic()
                if now >= next_hello:
                    next_hello = now + self.config.hello_interval
                    send_message(server, make_hello(self.config.booth, self.hello_body()))
                if now >= next_beat:
                    next_beat += self.config.heartbeat_interval
                    send_message(uplink, self.heartbeat())
                timeout = max(0.0, min(next_hello, next_beat) - time.monotonic())
                if self._waiting:  # commands for a stage that is still connecting
                    self._retry(server, stages)
                    timeout = min(timeout, RETRY_INTERVAL)
                events = dict(poller.poll(min(POLL_MS, int(timeout * 1000) + 1)))
                if server in events:
                    self._drain(server, lambda f: self._on_command(f, server, stages))
                if stages in events:
                    self._drain(stages, lambda f: self._on_stage_reply(f, server))
                if sub in events:
                    for message in receive_messages(sub, self.errors):
                        self._on_stage_message(message, uplink)
            # The other stages have stopped (the worker stops the hub last): what they said
            # on the way out (the robot closed, a recording stopped) still goes to the server.
            deadline = time.monotonic() + FINAL_DRAIN_LIMIT
            while sub.poll(FINAL_DRAIN_MS) and time.monotonic() < deadline:
                for message in receive_messages(sub, self.errors):
                    self._on_stage_message(message, uplink)
        finally:
            uplink.close(linger=FINAL_LINGER_MS)
            for socket in (server, stages, sub):
                socket.close(linger=0)

    def _open(self) -> tuple[zmq.Socket[bytes], ...]:
        ctx, endpoints = self.context, self.endpoints
        server = ctx.socket(zmq.DEALER)
        server.setsockopt(zmq.IDENTITY, self.config.booth.encode())
        server.setsockopt(zmq.SNDHWM, 1000)
        uplink = ctx.socket(zmq.PUB)
        uplink.setsockopt(zmq.SNDHWM, 10000)
        stages = ctx.socket(zmq.ROUTER)
        stages.setsockopt(zmq.ROUTER_MANDATORY, 1)  # an absent stage is an error, not silence
        sub = ctx.socket(zmq.SUB)
        for socket in (server, uplink, stages, sub):
            socket.setsockopt(zmq.LINGER, 0)
        if self.config.curve is not None:
            for socket in (server, uplink):
                apply_client(socket, self.config.curve)
        server.connect(self.config.command_endpoint)
        uplink.connect(self.config.telemetry_endpoint)
        stages.bind(endpoints.stage_control)
        for prefix in (STATS_PREFIX, EVENT_PREFIX, DISPLAY_PREFIX):
            sub.setsockopt(zmq.SUBSCRIBE, prefix.encode())
        for endpoint in (endpoints.agent, endpoints.playback, endpoints.render, endpoints.recorder):
            sub.connect(endpoint)
        return server, uplink, stages, sub

    @staticmethod
    def _drain(socket: zmq.Socket[bytes], handle: Callable[[list[bytes]], None]) -> None:
        for _ in range(1000):
            try:
                frames = socket.recv_multipart(zmq.NOBLOCK)
            except zmq.Again:
                return
            handle(frames)

    def _on_command(
        self, frames: list[bytes], server: zmq.Socket[bytes], stages: zmq.Socket[bytes]
    ) -> None:
        if frames and frames[0] == _CAPTURE:
            self._on_capture(frames)
            return
        try:
            command = parse_command(frames)
            if command.type == STATUS:
                self.commands["ok"] += 1
                send_message(server, make_ack(command, self.status(), source=self.name))
                return
            if command.type in self.local:
                result = self.local[command.type](command.body)
                self.commands["ok"] += 1
                send_message(server, make_ack(command, dict(result), source=self.name))
                return
            if command.type not in ROUTES:
                raise CommandError("unsupported", f"this worker does not handle {command.type}",
                                   seq=command.seq, command=command.type)  # fmt: skip
            self._forward(command, frames, stages)
        except CommandError as exc:
            self.errors[f"command_{exc.reason}"] += 1
            self.commands["failed"] += 1
            send_message(server, make_error_ack(exc, source=self.name))

    def _on_capture(self, frames: list[bytes]) -> None:
        if self.capture is None:
            self.errors["capture_unexpected"] += 1
            return
        try:
            self.capture(deserialize(frames))
        except EnvelopeError as exc:
            self.errors[f"capture_{exc.reason}"] += 1

    def _forward(self, command: Command, frames: list[bytes], stages: zmq.Socket[bytes]) -> None:
        stage = ROUTES[command.type]
        try:
            stages.send_multipart([stage.encode(), *frames], zmq.NOBLOCK)
        except zmq.ZMQError:
            # Not connected (yet): over ipc/tcp a stage's connection completes a moment
            # after it starts. Retry for a while before answering with an error.
            deadline = time.monotonic() + STAGE_WAIT
            self._waiting.append((deadline, command, frames))

    def _retry(self, server: zmq.Socket[bytes], stages: zmq.Socket[bytes]) -> None:
        waiting, self._waiting = self._waiting, []
        now = time.monotonic()
        for deadline, command, frames in waiting:
            stage = ROUTES[command.type]
            try:
                stages.send_multipart([stage.encode(), *frames], zmq.NOBLOCK)
            except zmq.ZMQError as exc:
                if now < deadline:
                    self._waiting.append((deadline, command, frames))
                    continue
                error = CommandError("stage_unavailable", f"{stage}: {exc.strerror}",
                                     seq=command.seq, command=command.type)  # fmt: skip
                self.errors["command_stage_unavailable"] += 1
                self.commands["failed"] += 1
                send_message(server, make_error_ack(error, source=self.name))

    def _on_stage_reply(self, frames: list[bytes], server: zmq.Socket[bytes]) -> None:
        try:
            ack = deserialize(frames[1:])
        except EnvelopeError as exc:
            self.errors[f"stage_{exc.reason}"] += 1
            return
        self.commands["ok" if ack.body.get("ok") else "failed"] += 1
        send_message(server, ack)

    def _on_stage_message(self, message: Message, uplink: zmq.Socket[bytes]) -> None:
        topic = message.topic
        if topic.startswith(STATS_PREFIX):
            self.latest[topic[len(STATS_PREFIX) :]] = (time.monotonic(), message.body)
        elif topic.startswith(EVENT_PREFIX):
            forwarded = Message(event_topic(self.config.booth), message.type, message.seq,
                                message.source, message.time, message.body)  # fmt: skip
            send_message(uplink, forwarded)
        elif topic.startswith(DISPLAY_PREFIX):
            send_message(uplink, message)

    def hello_body(self) -> dict[str, Any]:
        return {"instance": self.instance, "pid": os.getpid(), "version": __version__,
                "uptime_s": time.monotonic() - self.started, **self.config.info}  # fmt: skip

    def _stage(self, name: str) -> dict[str, Any]:
        return self.latest.get(name, (0.0, {}))[1]

    def status(self) -> dict[str, Any]:
        """The heartbeat's content: what the wizard console shows about this booth."""
        now = time.monotonic()
        renderer, behaviour = self._stage("renderer"), self._stage("behaviour")
        ingest = dict(self.ingest_stats()) if self.ingest_stats else {}
        driver = renderer.get("driver", {})
        input_fps = ingest.get("input_fps", behaviour.get("input_fps"))
        return {
            "booth": self.config.booth, "instance": self.instance,
            "uptime_s": now - self.started,
            "behaviour": behaviour.get("behaviour"), "behaviour_params": behaviour.get("params"),
            # The copied head: re-centred or not, on which neutral pose (booth check, events).
            "head": behaviour.get("head"),
            "tick_rate_hz": renderer.get("tick_rate_hz"),
            "jitter_ms": {k: renderer.get(f"jitter_{k}_ms") for k in ("p50", "p99", "max")},
            "missed_ticks": renderer.get("missed_ticks"), "input_fps": input_fps,
            "capture_to_send_ms": renderer.get("capture_to_send_ms"),
            "robot_connected": renderer.get("robot_connected", False),
            "robot_state": renderer.get("robot_state"), "driver": driver.get("name"),
            # Why the robot is not connected (a refused login) and face problems: the
            # wizard's health strip shows them.
            "robot_problem": driver.get("problem"),
            "robot_retry_in": driver.get("retry_in"),  # seconds to the next login attempt
            "robot_face": {k: driver.get(k) for k in ROBOT_FACE_FIELDS if k in driver},
            # A booth with both robots (virtual+furhat): the one driven now, and each one's
            # state (the console says when the one a later condition needs is missing).
            "robot_active": driver.get("active"),
            "robot_outputs": _outputs(driver.get("outputs")),
            "speaking": renderer.get("speaking", False), "prompt_id": renderer.get("prompt_id"),
            "recording": self._stage("recorder"),
            # The copy delay measured movement to movement (booth check; None: no movement).
            "movement_delay": self._stage("recorder").get("movement_delay"),
            "movement_brows": self._stage("recorder").get("movement_brows"),  # raised vs copied
            "drops": {"ingest": ingest.get("drops", {}), "behaviour": behaviour.get("errors", {}),
                      "renderer": renderer.get("errors", {}),
                      "driver": driver.get("dropped", 0), "hub": dict(self.errors)},
            "commands": dict(self.commands),
            "stages": {name: round(now - seen, 3) for name, (seen, _) in self.latest.items()},
            "ingest": ingest,
        }  # fmt: skip

    def heartbeat(self) -> Message:
        self._heartbeats += 1
        return Message(telemetry_topic(self.config.booth), "heartbeat", self._heartbeats,
                       self.name, time.monotonic(), self.status())  # fmt: skip


def _outputs(outputs: Any) -> dict[str, dict[str, Any]] | None:
    """Each robot's state, problem and retry time (a two-robot driver's ``outputs``)."""
    if not isinstance(outputs, Mapping):
        return None
    return {str(name): {k: stats.get(k) for k in ROBOT_OUTPUT_FIELDS}
            for name, stats in outputs.items() if isinstance(stats, Mapping)}  # fmt: skip
